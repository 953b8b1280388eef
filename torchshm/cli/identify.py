"""``torchshm-identify``: the Hydra application (also ``python scripts/identify.py``).

Hydra stays at this edge: it composes ``conf/config.yaml`` with the command-line overrides,
:func:`torchshm.config.to_settings` turns the result into typed dataclasses, and
:func:`torchshm.cli.job.run_job` calls the library. Each run writes into its own folder under
``runs/`` (``hydra.run.dir``; sweeps under ``runs/multirun/``), relative to the directory the
command runs from (``hydra.job.chdir`` is false).

A bad input (missing or malformed data file, unknown load case, unknown config option, inverted
bounds) ends with exit status 2 and one line on stderr, ``torchshm-identify: error: ...``;
``HYDRA_FULL_ERROR=1`` shows the traceback instead.

SIGTERM (Slurm's pre-emption and time limit) and Ctrl-C stop the run at once with one line on
stderr: every finished model run is kept in the store, and the same command resumes (exit
status 143 after SIGTERM, 130 after Ctrl-C).
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path
from typing import Sequence

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from torchshm.cli.errors import BadInput, bad_input_in_job, one_line, report_bad_input
from torchshm.config import CONF_DIR, CONFIG_NAME, normalize_overrides, register_configs, to_settings
from torchshm.inference.peer_errors import PeerNumericalError
from torchshm.inference.target import ModelRunsFailed
from torchshm.storage.interrupt import EXIT_SIGINT, resumable, store_of

PROG = "torchshm-identify"

log = logging.getLogger(__name__)

register_configs()  # also in the worker processes of a parallel sweep (joblib launcher)
# ArviZ logs "arviz_base not installed" (x3) at INFO when it is first imported, which is now
# inside the run (Hydra's loggers configured): keep it out of the console and the run's log
logging.getLogger("arviz.preview").setLevel(logging.WARNING)


@hydra.main(config_path=str(CONF_DIR), config_name=CONFIG_NAME, version_base="1.3")
def _app(cfg: DictConfig) -> float | None:
    """Hydra's task function: typed settings in, one run folder out.

    Returns:
        The log evidence (ELBO) of the run, or None (emcee), for Hydra's sweepers.
    """
    from torchshm.cli.job import prepare_job, run_job  # the methods' libraries load here

    logging.captureWarnings(True)  # warnings go to the run's log, not to stderr
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    with bad_input_in_job(out_dir):  # only the inputs: a later failure is a failed run
        settings = to_settings(cfg)
        job = prepare_job(settings, base=Path(hydra.utils.get_original_cwd()))
    with resumable(PROG, store_of(job.problem), how="run the same command again"):
        try:
            result = run_job(job, out_dir)
        except (ModelRunsFailed, PeerNumericalError) as err:  # one line, as for bad input
            raise BadInput(one_line(err)) from err
    post = result.posterior
    log.info("%d model evaluations in %.1f s; outputs in %s",
             post.n_model_evaluations, result.wall_time_s, out_dir)
    return post.log_evidence


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point of ``torchshm-identify``.

    Args:
        argv: command-line arguments (default ``sys.argv[1:]``): Hydra overrides and flags,
            e.g. ``kernel=matern52 resolution=0.5`` or ``-m kernel=matern32,matern52``.
    """
    register_configs()
    args = sys.argv[1:] if argv is None else list(argv)
    sys.argv = [sys.argv[0] if sys.argv else PROG, *normalize_overrides(args)]
    try:
        with report_bad_input(PROG):
            _app()
    except KeyboardInterrupt:  # Ctrl-C: the resume line is printed already, no traceback
        raise SystemExit(EXIT_SIGINT) from None


if __name__ == "__main__":
    main()
