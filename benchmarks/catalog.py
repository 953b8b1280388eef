"""The twelve cases of the suite (:data:`CASES`), each built from :mod:`benchmarks.models`.

Stiffness ranges are physical: a rotational spring of ``10**log10_k`` N·m/rad against the
span's ``4 EI / L`` (about 10^9.3 here) goes from a pin (below ~10^7.5) to a clamp (above
~10^11), so a prior over 5..13 has flat ends; a vertical spring against ``48 EI / L³``.
"""

from __future__ import annotations

from functools import partial

from benchmarks.cases import Case, G, U
from benchmarks.models import Beam, BeamSpec, OrthotropicPlate, Role

I = 0.3  # second moment of area of the beams [m^4]


def _beam(name: str, spec: BeamSpec, roles: dict[str, Role]) -> partial[Beam]:
    return partial(Beam, spec, roles, name)


def _ga(bounds: bool = True, top: float = 10.0) -> G:
    """The σa prior: Gamma(2, 1) [µε], truncated to (0, top) unless ``bounds`` is False."""
    return G(2.0, 1.0, bounds=(0.0, top)) if bounds else G(2.0, 1.0)


def _gl(mean: float, bounds: bool = True, top: float = 20.0) -> G:
    """The length prior: Gamma(2, 2 / mean) [m], truncated to (0, top) unless ``bounds`` is False."""
    return G(2.0, 2.0 / mean, bounds=(0.0, top)) if bounds else G(2.0, 2.0 / mean)


SINGLE = BeamSpec(supports=(0.0, 20.0), element=0.5, sensors=(0.25, 19.75, 0.25), loads=(8.0, 14.0, 20.0),
                  inertia=I)
TWO_SPAN = BeamSpec(supports=(0.0, 18.0, 36.0), element=0.5, sensors=(0.25, 35.75, 0.25),
                    loads=(10.0, 22.0, 32.0), inertia=I)
THREE_SPAN = BeamSpec(supports=(0.0, 15.0, 35.0, 50.0), element=0.5, sensors=(0.5, 49.5, 0.5),
                      loads=(8.0, 18.0, 27.0, 36.0, 46.0), inertia=I)
FIBRES = BeamSpec(supports=(0.0, 20.0, 40.0), element=0.5, sensors=(0.25, 39.75, 0.25),
                  loads=(8.0, 22.0, 34.0), inertia=I, lines={"bottom": 0.6, "top": -0.4})

_cases = [
    Case("beam2_saturating", "log10 spring saturating above ~11 (flat posterior); 3 loads",
         _beam("beam2_saturating", SINGLE, {"E": Role("modulus"), "log10_k_A": Role("log10_rot", support=0)}),
         {"E": 34.0, "log10_k_A": 11.6}, 1.0, 2.0,
         {"E": U(15, 60, plausible=(20, 50)), "log10_k_A": U(5, 13, plausible=(6, 12)),
          "sigma_a": _ga(), "length": _gl(2.0)}, "matern32", seed=11),
    Case("beam2_user_gamma", "Gamma(2, 2) priors on σa and l without bounds; 1 load",
         _beam("beam2_user_gamma", BeamSpec(supports=(0.0, 15.0, 30.0), element=0.5, sensors=(0.25, 29.75, 0.25),
                                              loads=(12.0,), inertia=I),
               {"E": Role("modulus"), "log10_kv_B": Role("log10_vert", support=1)}),
         {"E": 30.0, "log10_kv_B": 8.3}, 0.8, 1.0,
         {"E": U(15, 60, plausible=(20, 50)), "log10_kv_B": U(7, 10, plausible=(7.5, 9.5)),
          "sigma_a": G(2.0, 2.0), "length": G(2.0, 2.0)}, "squared_exponential", seed=12),
    Case("plate2_field", "DIC field, 192 points (n x 2); 2 patch loads",
         partial(OrthotropicPlate), {"E_x": 32.0, "E_y": 24.0}, 0.6, 0.5,
         {"E_x": U(10, 60, plausible=(15, 50)), "E_y": U(10, 60, plausible=(15, 50)),
          "sigma_a": _ga(), "length": _gl(0.5, top=3.0)}, "matern52", seed=13),
    Case("low_noise2", "data with σm = 0.005, σe = 0.05 µε; identified with default σm = 0.05",
         _beam("low_noise2", BeamSpec(supports=(0.0, 25.0), element=0.5, sensors=(0.25, 24.75, 0.25),
                                       loads=(9.0, 15.0, 21.0), inertia=I, fixed_rot=((0, 9.0),)),
               {"E": Role("modulus"), "log10_k_B": Role("log10_rot", support=1)}),
         {"E": 33.0, "log10_k_B": 9.0}, 0.3, 2.0,
         {"E": U(15, 60, plausible=(20, 50)), "log10_k_B": U(6, 12, plausible=(7, 11)),
          "sigma_a": _ga(), "length": _gl(2.0)}, "matern32", seed=14, data_sigma_m=0.005, data_sigma_e=0.05),
    Case("beam3_ridge", "fibre depth and E: strongly correlated pair; 4 loads",
         _beam("beam3_ridge", BeamSpec(supports=(0.0, 22.0), element=0.5, sensors=(0.25, 21.75, 0.25),
                                        loads=(7.0, 11.0, 16.0, 22.0), inertia=I, fixed_rot=((1, 9.5),)),
               {"E": Role("modulus"), "depth": Role("depth"), "log10_k_A": Role("log10_rot", support=0)}),
         {"E": 35.0, "depth": 0.6, "log10_k_A": 9.0}, 0.7, 1.5,
         {"E": U(20, 50, plausible=(25, 45)), "depth": U(0.4, 0.8, plausible=(0.45, 0.75)),
          "log10_k_A": U(6, 12, plausible=(7, 11)), "sigma_a": _ga(), "length": _gl(1.5)}, "exponential", seed=15),
    Case("beam3_bimodal", "two cracks of known depth, positions unknown: two modes (labels swap)",
         _beam("beam3_bimodal", BeamSpec(supports=(0.0, 20.0), element=0.25, sensors=(0.2, 19.8, 0.2),
                                          loads=(8.0, 16.0), inertia=I),
               {"E": Role("modulus"), "crack_1": Role("damage_pos", width=0.6, depth=0.3),
                "crack_2": Role("damage_pos", width=0.6, depth=0.3)}),
         {"E": 34.0, "crack_1": 6.0, "crack_2": 13.0}, 0.3, 1.0,
         {"E": U(25, 45, plausible=(28, 42)), "crack_1": U(1, 19, plausible=(2, 18)),
          "crack_2": U(1, 19, plausible=(2, 18)), "sigma_a": _ga(top=5.0)}, "independent", seed=16,
         extra={"starts": [{"crack_1": 13.0, "crack_2": 6.0}]}),
    Case("beam3_two_span", "Gamma priors without bounds; 3 loads; large model error",
         _beam("beam3_two_span", TWO_SPAN, {"E": Role("modulus"), "log10_k_A": Role("log10_rot", support=0),
                                            "log10_k_C": Role("log10_rot", support=2)}),
         {"E": 31.0, "log10_k_A": 9.2, "log10_k_C": 8.6}, 2.5, 3.0,
         {"E": U(15, 60, plausible=(20, 50)), "log10_k_A": U(6, 12, plausible=(7, 11)),
          "log10_k_C": U(6, 12, plausible=(7, 11)), "sigma_a": G(2.0, 1.0), "length": G(2.0, 0.5)},
         "matern52", seed=17),
    Case("beam4_bridge", "modulus, pavement factor, two springs (one weak, saturating); 3 loads",
         _beam("beam4_bridge", TWO_SPAN, {"E": Role("modulus"), "pavement": Role("factor", span=(18.0, 36.0)),
                                          "log10_k_A": Role("log10_rot", support=0),
                                          "log10_k_C": Role("log10_rot", support=2)}),
         {"E": 36.0, "pavement": 1.15, "log10_k_A": 9.5, "log10_k_C": 11.3}, 1.5, 3.0,
         {"E": U(15, 60, plausible=(20, 50)), "pavement": U(0.9, 1.4, plausible=(0.95, 1.3)),
          "log10_k_A": U(6, 12, plausible=(7, 11)), "log10_k_C": U(6, 12, plausible=(7, 11)),
          "sigma_a": _ga(), "length": _gl(3.0)}, "matern52", seed=18),
    Case("beam4_unidentified", "far-end spring without effect on the data (unidentified); 2 loads",
         _beam("beam4_unidentified", BeamSpec(supports=(0.0, 12.0, 24.0, 36.0), element=0.5,
                                               sensors=(0.25, 11.75, 0.25), loads=(6.0, 11.0), inertia=I),
               {"E1": Role("modulus", span=(0.0, 12.0)), "E2": Role("modulus", span=(12.0, 36.0)),
                "log10_kv_B": Role("log10_vert", support=1), "log10_k_D": Role("log10_rot", support=3)}),
         {"E1": 33.0, "E2": 28.0, "log10_kv_B": 8.8, "log10_k_D": 9.0}, 0.5, 1.0,
         {"E1": U(15, 60, plausible=(20, 50)), "E2": U(15, 60, plausible=(20, 50)),
          "log10_kv_B": U(7.5, 10.5, plausible=(8, 10)), "log10_k_D": U(6, 12, plausible=(7, 11)),
          "sigma_a": _ga(), "length": _gl(1.0)}, "exponential", seed=19, unidentified=("log10_k_D",)),
    Case("fibres4_dropouts", "two fibres (bottom, top), 5 % dropouts and a 1 m gap; cracked zone",
         _beam("fibres4_dropouts", FIBRES, {"E": Role("modulus"), "cracked": Role("factor", span=(15.0, 25.0)),
                                            "log10_k_A": Role("log10_rot", support=0),
                                            "log10_k_C": Role("log10_rot", support=2)}),
         {"E": 33.0, "cracked": 0.7, "log10_k_A": 8.8, "log10_k_C": 9.6}, 1.0, 2.5,
         {"E": U(15, 60, plausible=(20, 50)), "cracked": U(0.4, 1.0, plausible=(0.5, 0.95)),
          "log10_k_A": U(6, 12, plausible=(7, 11)), "log10_k_C": U(6, 12, plausible=(7, 11)),
          "sigma_a": _ga(), "length": _gl(2.5)}, "matern32", seed=20, dropouts=(0.05, 1.0)),
    Case("beam6_large_error", "three spans, 6 parameters, σa = 3 µε; 5 loads",
         _beam("beam6_large_error", THREE_SPAN,
               {"E1": Role("modulus", span=(0.0, 15.0)), "E2": Role("modulus", span=(15.0, 35.0)),
                "E3": Role("modulus", span=(35.0, 50.0)), "log10_k_A": Role("log10_rot", support=0),
                "log10_k_D": Role("log10_rot", support=3), "log10_kv_B": Role("log10_vert", support=1)}),
         {"E1": 30.0, "E2": 36.0, "E3": 27.0, "log10_k_A": 9.4, "log10_k_D": 8.7, "log10_kv_B": 8.6}, 3.0, 3.0,
         {**{f"E{i}": U(15, 60, plausible=(20, 50)) for i in (1, 2, 3)},
          "log10_k_A": U(6, 12, plausible=(7, 11)), "log10_k_D": U(6, 12, plausible=(7, 11)),
          "log10_kv_B": U(7.5, 10.5, plausible=(8, 10)), "sigma_a": _ga(), "length": _gl(3.0)},
         "matern32", seed=21),
    Case("beam6_small_error", "two spans, 6 parameters, σa = 0.3 µε; 6 point loads",
         _beam("beam6_small_error", BeamSpec(supports=(0.0, 16.0, 32.0), element=0.5, sensors=(0.25, 31.75, 0.25),
                                              loads=(4.0, 8.0, 12.0, 20.0, 24.0, 28.0), inertia=I, point_loads=True),
               {"E": Role("modulus"), "crack_1": Role("factor", span=(6.0, 10.0)),
                "crack_2": Role("factor", span=(14.0, 18.0)), "log10_k_A": Role("log10_rot", support=0),
                "log10_k_C": Role("log10_rot", support=2), "log10_kv_B": Role("log10_vert", support=1)}),
         {"E": 32.0, "crack_1": 0.8, "crack_2": 0.6, "log10_k_A": 8.9, "log10_k_C": 9.3, "log10_kv_B": 8.9},
         0.3, 4.0,
         {"E": U(15, 60, plausible=(20, 50)), "crack_1": U(0.4, 1.0, plausible=(0.5, 0.95)),
          "crack_2": U(0.4, 1.0, plausible=(0.5, 0.95)), "log10_k_A": U(6, 12, plausible=(7, 11)),
          "log10_k_C": U(6, 12, plausible=(7, 11)), "log10_kv_B": U(7.5, 10.5, plausible=(8, 10)),
          "sigma_a": _ga(), "length": _gl(4.0)}, "squared_exponential", seed=22),
]

#: name -> :class:`Case`, in the order of the tables
CASES: dict[str, Case] = {c.name: c for c in _cases}
