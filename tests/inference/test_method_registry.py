"""A method registered in one place runs through ``identify`` with the same checks as the
built-in ones; an unknown name is refused before any model run, naming the registered ones."""

from __future__ import annotations

import pytest

import torchshm
from torchshm.inference import registry
from torchshm.inference.posterior import Posterior
from torchshm.inference.registry import Method, get_method, method_names, refuse, resolve_aliases
from tests.inference.test_validate import Counting, problem_of


def run_prior(problem, seed, *, log_dir=None, n_draws: int = 64) -> Posterior:
    """A stand-in method: the posterior is the prior (no model run)."""
    samples = problem.sample_prior(n_draws, seed)
    return Posterior(names=list(problem.names), method="prior", samples=samples, converged=False,
                     priors=dict(problem.priors), problem=problem)


def _check(options: dict, dim: int) -> None:
    if options["n_draws"] < 2 * dim:
        refuse("prior", f"n_draws must be at least {2 * dim}")


@pytest.fixture()
def prior_method(monkeypatch: pytest.MonkeyPatch) -> Method:
    method = Method("prior", run_prior, check=_check,
                    not_converged=lambda post: "NOT CONVERGED: the prior method never converges")
    monkeypatch.setitem(registry._METHODS, "prior", method)  # undone after the test
    return method


def test_the_built_in_methods_are_registered() -> None:
    assert {"vbmc", "emcee", "emulator"} <= set(method_names())
    assert get_method("vbmc").has_evidence and not get_method("emcee").has_evidence


def test_a_registered_method_runs_with_the_common_checks(prior_method: Method) -> None:
    model = Counting()
    post = torchshm.identify(problem_of(model), method="prior", seed=1, n_draws=32)
    assert post.method == "prior" and post.samples.shape == (32, 3)
    assert post.warnings[0] == "NOT CONVERGED: the prior method never converges"
    assert model.calls == 1  # the output check's one run, at the plausible box's centre
    with pytest.raises(ValueError, match="has no option 'n_walkers'; its options: n_draws"):
        torchshm.identify(problem_of(Counting()), method="prior", n_walkers=8)
    refused = Counting()
    with pytest.raises(ValueError, match=r"method='prior': n_draws must be at least 6"):
        torchshm.identify(problem_of(refused), method="prior", n_draws=4)
    assert refused.calls == 0


def test_an_unknown_method_is_refused_before_any_model_run(prior_method: Method) -> None:
    model = Counting()
    with pytest.raises(ValueError, match=r"unknown method 'priors' \(did you mean 'prior'\?\); "
                                         r"choose one of \(.*'emulator'.*'prior'\)"):
        torchshm.identify(problem_of(model), method="priors")
    assert model.calls == 0


def test_an_alias_is_renamed_before_the_checks_and_an_unset_one_dropped() -> None:
    assert resolve_aliases("vbmc", {"max_model_evaluations": 40, "display": "off"}) == \
        {"max_fun_evals": 40, "display": "off"}
    assert resolve_aliases("vbmc", {"max_model_evaluations": None, "max_fun_evals": 50}) == {"max_fun_evals": 50}
    assert resolve_aliases("emulator", {"max_model_evaluations": 40}) == {"max_model_evaluations": 40}  # its own
    with pytest.raises(ValueError, match="name the same setting"):
        resolve_aliases("vbmc", {"max_model_evaluations": 40, "max_fun_evals": 50})
    with pytest.raises(ValueError, match="unknown method"):
        resolve_aliases("vmbc", {})


def test_identify_takes_vbmcs_budget_under_the_emulators_name() -> None:
    model = Counting()
    with pytest.raises(ValueError, match=r"max_fun_evals \(method.max_fun_evals\) must be at least"):
        torchshm.identify(problem_of(model), method="vbmc", max_model_evaluations=3)  # as max_fun_evals=3 is
    assert model.calls == 0


def test_emcee_keeps_within_a_budget_of_model_runs_and_says_the_budget_ended_it() -> None:
    model = Counting()
    post = torchshm.identify(problem_of(model), method="emcee", seed=0, n_walkers=8, n_steps=1000,
                             max_model_evaluations=50)
    assert model.calls <= 50 and post.n_model_evaluations == model.calls  # the output check included
    assert post.diagnostics["n_steps"] == (50 - 1) // 8 - 1 and post.diagnostics["capped_by_budget"]
    assert not post.converged and "raise max_model_evaluations" in post.warnings[0]
    refused = Counting()
    with pytest.raises(ValueError, match=r"max_model_evaluations \(method.max_model_evaluations\) = 20 leaves 1 step"):
        torchshm.identify(problem_of(refused), method="emcee", n_walkers=8, max_model_evaluations=20)
    assert refused.calls == 0
