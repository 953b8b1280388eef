"""``identify(problem, method="emulator")``: few model runs, in concurrent batches.

The steps, one round at a time:

1. run the model at a batch of θp, concurrently and through the store (round 0: a Latin
   hypercube of ``n_initial`` points in the plausible box; runs already in the store, e.g. of
   another kernel or resolution, are used too);
2. fit the field emulator of the measured strains over θp (:mod:`.field`);
3. sample the posterior of all parameters on the emulated likelihood, Eq. (21) at the
   emulator's mean (:mod:`.likelihood`, :mod:`.sampling`; no model run), the walkers first
   spread over the modes found by a multi-start search (:mod:`.modes`);
4. check the stop rule: the total variation between this round's posterior and the previous
   one's, or the one the emulator's uncertainty allows (:mod:`.witness`), is below ``tv_tol``
   in ``patience`` successive rounds, the emulator causes less than ``sd_tol`` nats of
   log-likelihood uncertainty on average over the posterior (to first order; where that fails,
   its possible errors move the log evidence by less than ``sd_tol``: :func:`.evidence_spread`
   over joint draws of it), the batch just run was predicted
   within ``check_tol`` nats (:mod:`.validation`) and no point of the box is unresolved
   (:mod:`.explore`); or the budget of model runs is spent;
5. otherwise choose the next batch where the emulator's uncertainty matters most under the
   posterior (:mod:`.acquisition`), one run at unresolved points and, once the rest of the
   rule holds, only the runs it still waits for (past the runs' range, unresolved points),
   and go to 1.

The returned :class:`~torchshm.inference.Posterior`: a mixture density fitted to a chain on the
last emulator, draws and log evidence by importance sampling from it (:mod:`.sampling`; a pilot
of it must lie within the runs' range before the rule may stop: :mod:`.tail`), and
``diagnostics["rounds"]``.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch

from torchshm.inference import blas
from torchshm.inference.adaptive import cost
from torchshm.inference.adaptive import modes as mode_search
from torchshm.inference.adaptive import sampling
from torchshm.inference.adaptive.acquisition import choose_batch, design
from torchshm.inference.adaptive.budget import default_cap, default_n_initial, positive  # noqa: F401
from torchshm.inference.adaptive.explore import (beyond_posterior, explore, explore_calibration,
                                                  exploration_batch, with_modes)
from torchshm.inference.adaptive.field import DEFAULT_KERNEL, FieldEmulator, model_transform
from torchshm.inference.adaptive.final import (EXTRAPOLATION_SHARE, beyond_rows, edge_rows,
                                                extrapolation_run, finish)
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint, physical_columns
from torchshm.inference.adaptive.runs import RunSet, run_batch
from torchshm.inference.adaptive.tail import TAIL_MOVE, unseen_tail
from torchshm.inference.adaptive.unsure import (EVIDENCE_DRAWS, EVIDENCE_FIELDS, EVIDENCE_UPPER,
                                                 evidence_spread)
from torchshm.inference.adaptive.validation import check_batch
from torchshm.inference.adaptive.witness import tv_witness
from torchshm.inference.posterior import Posterior
from torchshm.inference.tensorboard import RunTrace, marginal_scalars

if TYPE_CHECKING:
    from torchshm.problem import Problem

logger = logging.getLogger(__name__)


def run_emulator(
    problem: Problem, seed: int = 0, *, log_dir: str | Path | None = None, batch_size: int = 5,
    max_model_evaluations: int | None = None, n_jobs: int = 1, executor: Any | None = None,
    n_initial: int | None = None, n_walkers: int | None = None, n_steps: int = 50,
    final_steps: int = 50, tv_tol: float = 0.05, patience: int = 1, sd_tol: float = 0.3,
    check_tol: float = 1.0, n_evidence: int = 8000, emulator_kernel: str = DEFAULT_KERNEL,
    error_draws: int | None = None,
) -> Posterior:
    """Identify ``problem`` with the adaptive field emulator (see :func:`torchshm.identify`).

    Args:
        problem: a :class:`~torchshm.Problem` (any campaign: sensor lines, dropouts,
            interpolated positions, 2-D fields); a store makes runs crash-safe and parallel.
        seed: seed of the design, the chains and the evidence draws.
        log_dir: TensorBoard folder (one row of scalars per round), or None.
        batch_size: model runs per round after the initial design.
        max_model_evaluations: cap on new model runs (None: PyVBMC's default budget
            ``50 (D + 2)``, D the inferred parameters); the stop rule normally ends the run long
            before. 0 identifies from the runs in the store alone.
        n_jobs: local worker processes for a batch (joblib; needs a store when != 1).
        executor: a submitit executor (:func:`torchshm.storage.make_executor`; needs a store).
        n_initial: size of the initial design (None: the smallest multiple of ``batch_size``
            of at least ``2 P + 1``).
        n_walkers: emcee walkers (None: ``max(96, 12 D)``: a likelihood call costs about the
            same for 10 or 50 walkers and emcee makes two calls per step, so many walkers and
            few steps are cheaper than the reverse).
        n_steps: emcee steps per round (the second half is kept; twice as many in round 0,
            whose walkers start from the prior).
        final_steps: emcee steps on the last emulator after the last round's chain (which ran
            on it), whose samples together fit the posterior's mixture density.
        tv_tol, patience: stop once the total variation to the previous round's posterior is
            below ``tv_tol`` in ``patience`` successive rounds...
        sd_tol: ...the emulator's log-likelihood sd, averaged over the posterior, is below
            ``sd_tol`` nats...
        check_tol: ...the last batch of runs, made at posterior draws before the emulator
            saw them, was within ``check_tol`` nats of the emulator's log-likelihood
            (:mod:`.validation`), no point of the plausible box may still hold a mode the
            emulator cannot rule out (:mod:`.explore`) and less than 5 % of the draws may lie
            beyond the runs' range (:data:`.final.EXTRAPOLATION_SHARE`).
        n_evidence: importance samples of the log evidence and the returned posterior draws.
        emulator_kernel: GP kernel of the field emulator (:data:`~torchshm.surrogate.gp.SURROGATE_KERNELS`):
            "matern52_additive_warped" (Matérn 5/2 ARD plus one per parameter, of inputs through
            a learned monotone warp: fewer runs over 36 cases, as accurate, docs/benchmarks.md),
            "matern52_additive", "matern52", "rbf", ... (their ``_additive``/``_warped`` forms).
        error_draws: joint draws of the emulator a capped run's posterior is averaged over
            (:mod:`.unsure`; None: 8 to 32, as ~30 CPU s allow, so machine-dependent; a number
            gives the same draws for a seed anywhere, a small one a cheap, rough average).

    Returns:
        The :class:`Posterior` (``method="emulator"``); ``converged`` is the stop rule's verdict
        (False when the cap ran out first, with a warning).

    The method's own work (small batched tensor operations) runs on one torch thread and one
    BLAS thread, restored afterwards and for model runs (:mod:`torchshm.inference.blas`): on a
    busy machine that is several times faster (the main job: 11–17 s CPU; 227 s on two threads).
    """
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # small batched operations: one thread, no spinning on a busy machine
    try:
        with blas.own_work():  # the same for NumPy's and SciPy's BLAS (a model run gets its own)
            return _run(problem, seed, log_dir, batch_size, max_model_evaluations, n_jobs, executor,
                        n_initial, n_walkers, n_steps, final_steps, tv_tol, patience, sd_tol,
                        check_tol, n_evidence, emulator_kernel, error_draws)
    finally:
        torch.set_num_threads(threads)


def _run(problem: Problem, seed: int, log_dir: str | Path | None, batch_size: int,
         max_model_evaluations: int | None, n_jobs: int, executor: Any | None,
         n_initial: int | None, n_walkers: int | None, n_steps: int, final_steps: int,
         tv_tol: float, patience: int, sd_tol: float, check_tol: float, n_evidence: int,
         emulator_kernel: str, error_draws: int | None = None) -> Posterior:
    """The rounds of :func:`run_emulator` (its arguments, in order)."""
    t0 = time.perf_counter()
    hard = np.asarray(problem.search_bounds, dtype=np.float64)
    plausible = np.asarray(problem.plausible_bounds, dtype=np.float64)
    names, dim = list(problem.names), len(problem.names)
    n_phys = len(problem.physical_names)
    batch_size = positive("batch_size", batch_size)
    n_initial = positive("n_initial", n_initial or default_n_initial(n_phys, batch_size))
    if max_model_evaluations is None:
        max_model_evaluations = default_cap(dim, n_initial, batch_size)
    budget = positive("max_model_evaluations", max_model_evaluations, minimum=0)
    n_walkers = int(n_walkers or max(96, 12 * dim))
    transform = model_transform(problem.model)
    rng = np.random.default_rng([seed, 29])
    runs = RunSet.from_problem(problem)
    n_reused = runs.theta_p.shape[0]
    trace = RunTrace(log_dir, step_key="round")
    rounds: list[dict[str, Any]] = []
    # a budget below the design (e.g. 0: "use the runs in the store") skips the design when
    # the store already holds enough runs to fit the emulator
    n_design = n_initial if budget >= n_initial or n_reused < n_phys + 2 else 0
    batch = physical_columns(problem, design(plausible, min(n_design, max(budget, n_phys + 2)),
                                             seed))
    batch_rows: np.ndarray | None = None
    walkers = sampling.walkers_from(problem.sample_prior(20 * n_walkers, rng), n_walkers, rng)
    previous: EmulatedLogJoint | None = None
    emulator: FieldEmulator | None = None
    prev_samples: np.ndarray | None = None
    calm, converged, checked, inflation, far_calibration, n_modes = 0, False, False, 1.0, 1.0, 1
    far = modes = np.zeros((0, dim))  # modes: the last round's, which start its search again
    columns = ([names.index(n) for n in problem.physical_names if n in names],
               [i for i, n in enumerate(problem.physical_names) if n in names])
    x_index, loads = torch.arange(problem.y.shape[1], dtype=torch.float64), torch.as_tensor(np.asarray(problem.measurements.loads, dtype=np.float64))
    if budget > 0:  # the own compute to expect, before the first model run
        cost.announce(problem, cost.estimate(problem, n_walkers, n_steps, final_steps, n_evidence,
                                             np.random.default_rng([seed, 31]), error_draws))
    if n_reused:
        where = ("from the store" if problem.store is not None
                 else "made earlier by this problem (e.g. the output check)")
        logger.info("resumed: %d runs %s", n_reused, where)
    try:
        for r in range(budget + 1):
            t_round, c_round = time.perf_counter(), time.process_time()
            n_before = runs.theta_p.shape[0]
            with blas.model_work():
                new, outputs = run_batch(problem, runs, batch, n_jobs, executor)
            check = (check_batch(previous, emulator, batch_rows, outputs[:len(batch_rows)])
                     if previous is not None and emulator is not None and batch_rows is not None
                     and len(batch_rows) else None)
            if check is not None and np.isfinite(check.calibration):
                inflation = max(1.0, check.calibration)
            if previous is not None and far.shape[0]:  # the emulator's record at exploration runs
                far_calibration = explore_calibration(previous, far, outputs[len(batch_rows):],
                                                      far_calibration)
            emulator = FieldEmulator.fit(runs.theta_p, runs.outputs, x_index, loads, transform,
                                         emulator_kernel, previous=emulator)
            log_joint = EmulatedLogJoint(problem, emulator, inflation)
            steps = n_steps if r > 0 else 2 * n_steps
            scan = explore(log_joint, walkers[int(np.argmax(log_joint(walkers)))], columns[0],
                           plausible, rng, far_calibration)
            walkers, n_modes, modes = mode_search.spread(log_joint, walkers, runs.theta_p, columns,
                                                         hard, plausible, rng, np.concatenate([scan.top, modes]))
            scan = with_modes(scan, log_joint, modes, far_calibration, sd_tol)
            samples, walkers = sampling.run_chain(log_joint, walkers, steps, seed + 1000 * r,
                                                  hop=n_modes > 1)
            pick = rng.choice(samples.shape[0], min(600, samples.shape[0]), False)
            draws = samples[pick]
            if n_modes == 1:  # the draws' spread is one mode's: the scale of its flank
                scan = beyond_posterior(scan, draws, columns[0])
            tv = (sampling.total_variation(log_joint(draws), previous(draws))
                  if previous is not None else 1.0)
            mmtv = sampling.marginal_tv(samples, prev_samples) if prev_samples is not None else 1.0
            share, sd = log_joint.emulator_share(draws)
            # or the TV the emulator's own uncertainty allows, once a new batch tested it and
            # the batch before passed its test too (``checked`` is still the last round's)
            witness = (tv_witness(log_joint, draws, np.random.default_rng([seed, 37, r]), scale=check.witness_scale)
                       if check is not None and checked and tv >= tv_tol else np.nan)
            calm = calm + 1 if tv < tv_tol or witness < tv_tol else 0
            # a batch of exploration runs alone (below) leaves the last posterior check standing
            checked = (check.passed(check_tol) if check is not None
                       else checked and batch_rows is not None and not len(batch_rows))
            # the sd term: first order (cheap), else log Z's sd over joint draws of the emulator
            evidence_sd = (evidence_spread(log_joint, draws[:EVIDENCE_DRAWS], EVIDENCE_FIELDS,
                                           np.random.default_rng([seed, 43, r]))
                           if calm >= patience and checked and float(sd.mean()) >= sd_tol
                           else np.nan)
            sure = float(sd.mean()) < sd_tol or EVIDENCE_UPPER * evidence_sd < sd_tol
            settled = calm >= patience and sure and checked
            beyond = beyond_rows(draws, columns[0], runs.theta_p[:, columns[1]], hard)
            edge = edge_rows(draws, columns[0], runs.theta_p[:, columns[1]], hard)
            extrapolating = bool(edge.mean() >= EXTRAPOLATION_SHARE)  # the rule does not hold
            # a run past the runs: for draws beyond them at once, for draws at their edge once the
            # emulator passed its check at the posterior (a crude early posterior is broad and
            # lies at the edge of some range in most of its draws)
            extend = (beyond if beyond.mean() >= EXTRAPOLATION_SHARE
                      else edge if extrapolating and checked else None)
            converged = settled and scan.n_unresolved == 0 and not extrapolating
            tail, out_of = np.nan, draws  # the returned posterior lies within the runs too
            if converged:
                pilot, past, tail = unseen_tail(log_joint, samples, columns[0],
                                                runs.theta_p[:, columns[1]], hard, plausible, seed + r)
                if tail > TAIL_MOVE:
                    converged, out_of, extend = False, pilot, past
                    logger.info("round %d: the rule held, but a pilot of the final draws moves by "
                                "%.2g sd beyond the runs: a run there", r, tail)
            row = {"round": float(r), "n_runs": float(len(batch)), "n_new_runs": float(new),
                   "n_model_evaluations": float(runs.n_new), "n_emulator_runs":
                   float(runs.theta_p.shape[0]), "tv": tv, "tv_witness": witness, "mmtv": mmtv,
                   "n_modes": float(n_modes), "emulator_share": float(share.mean()), "emulator_share_max": float(share.max()),
                   "emulator_loglik_sd": float(sd.mean()), "evidence_sd": evidence_sd,
                   "emulator_inflation": inflation, "check_loglik_error": check.max_error if check is not None else np.nan,
                   "witness_scale": check.witness_scale if check is not None else np.nan,
                   "settled": float(settled), "extrapolating": float(extrapolating),
                   "n_unresolved": float(scan.n_unresolved), "explore_margin": scan.margin,
                   "explore_calibration": far_calibration, "beyond_runs": float(beyond.mean()),
                   "edge_runs": float(edge.mean()), "final_tail_move": tail,
                   "wall_time_s": time.perf_counter() - t_round,
                   "cpu_time_s": time.process_time() - c_round}
            row.update(marginal_scalars(names, samples))
            trace.log(row)
            reused = runs.theta_p.shape[0] - n_before - new
            logger.info("round %d: %d runs (%d new, %d from the store; %d new in all), TV %.3f, "
                        "emulator log-likelihood sd %.3f nats, last batch off by %.3g nats, "
                        "%d unresolved points of the box, %.0f%% of the draws beyond the runs (%.0f%% "
                        "at their edge or beyond)", r, len(batch), new, max(0, reused), runs.n_new, tv,
                        sd.mean(), row["check_loglik_error"], scan.n_unresolved, 100 * beyond.mean(),
                        100 * edge.mean())
            rounds.append({**row, "batch": np.asarray(batch).tolist()})
            left = budget - runs.n_new
            if converged or left <= 0:
                break
            want = min(batch_size, left)
            # one run past the runs' range, where the emulator extends what it saw
            ext = (extrapolation_run(out_of, extend, columns[0], runs.theta_p[:, columns[1]], hard)
                   if extend is not None else draws[:0])[:want]  # never past the cap
            want -= ext.shape[0]
            # exploration: one run; once settled, the batch holds only the runs the rule waits
            # for, the run past the runs and the exploration's (posterior draws with nothing
            # to learn would only fill it)
            alone = settled and (extend is not None or scan.n_unresolved > 0)
            k = want if alone else min(1, want)
            far = exploration_batch(scan, emulator, physical_columns(problem, scan.rows), k, rng)
            want = 0 if alone else want - far.shape[0]
            far = np.concatenate([far, ext])  # runs away from the posterior, checked apart
            batch, chosen = choose_batch(emulator, physical_columns(problem, draws), sd**2, want, rng)
            if len(chosen) < want:  # nothing left to learn by the rule: test at random draws
                extra = rng.choice(np.setdiff1d(np.arange(draws.shape[0]), chosen),
                                   want - len(chosen), replace=False)
                chosen = np.concatenate([chosen, extra])
                batch = physical_columns(problem, draws[chosen])
            batch_rows = draws[chosen]  # the posterior part, which the next round checks
            batch = np.concatenate([batch, physical_columns(problem, far)])
            previous, prev_samples = log_joint, samples
    finally:
        trace.close()
    return finish(problem, log_joint, walkers, samples, rounds, runs, trace, converged, seed, {
        "n_final_steps": final_steps, "n_walkers": n_walkers, "n_evidence": n_evidence,
        "n_reused_runs": n_reused, "budget": budget, "t0": t0, "hard": hard,
        "plausible": plausible, "hop": n_modes > 1, "error_draws": error_draws,
    })
