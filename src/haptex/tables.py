"""Table II of Campion & Hayward recomputed: characteristic number, loop energy,
measured conservativity and continuity for each algorithm, beside the paper's claims."""

from __future__ import annotations

import math

import numpy as np

from ._validation import fail, nonnegative, positive
from .algorithms import ALGORITHMS
from .analysis import characteristic_number, checked_algorithms, conservativity, continuity, paper_loop, path_work
from .surfaces import SumOfGratings
from .textures import Sinusoid

PAPER_PARAMETERS = {
    "stiffness": 2000.0,  # N/m, Section V-A
    "amplitude": 0.8e-3,  # m
    "period": 1e-3,  # m
    "max_penetration": 1e-3,  # m, d^z_max
    "friction": 0.8,  # mu
    "presliding": 1e-3,  # m, d^x_max
}
"""The paper's Section V-A parameters (SI): kappa_0, A, l, d^z_max, mu and d^x_max."""

TABLE_II_CLAIMS = {
    "W": {"characteristic_number": "1 (eq. 30)", "conservative": "Yes (gradient)", "continuous": "Yes"},
    "A": {"characteristic_number": "sqrt(1 + (2 pi A / l)^2)", "conservative": "No", "continuous": "If h continuous"},
    "B": {"characteristic_number": "No closed-form", "conservative": "No", "continuous": "If h' continuous"},
    "C": {"characteristic_number": "No closed-form", "conservative": "Yes", "continuous": "If h' continuous"},
    "D": {"characteristic_number": "1", "conservative": "Yes", "continuous": "No. Even if h continuous"},
    "E": {"characteristic_number": "1", "conservative": "No", "continuous": "If h continuous"},
    "F": {"characteristic_number": "Appendix I", "conservative": "Almost", "continuous": "If h continuous"},
    "G": {"characteristic_number": "No closed-form", "conservative": "No", "continuous": "If h' continuous"},
}
"""Table II as printed (W is not in the table; its row states what eq. 30 implies)."""

# The paper's own verdicts as booleans, for the smooth sinusoid of the experiments.
_EXPECTED = {
    "W": (True, True),
    "A": (False, True),
    "B": (False, True),
    "C": (True, True),
    "D": (True, False),
    "E": (False, True),
    "F": ("almost", True),
    "G": (False, True),
}


def _letters(letters) -> list:
    """``table_ii``'s letters as a list of upper-case strings (a string of letters or an
    iterable of one-letter strings), refused naming ``letters`` otherwise or when empty."""
    allowed = "a string of the letters W, A-G or a list of them, e.g. 'ABC' or ['A', 'B']"
    try:
        items = list(letters) if not isinstance(letters, bytes) else None
    except TypeError:
        items = None
    if not items or not all(isinstance(c, str) for c in items):
        raise fail("letters", letters, allowed)
    return [c.upper() for c in items]


def table_ii(stiffness: float = PAPER_PARAMETERS["stiffness"], amplitude: float = PAPER_PARAMETERS["amplitude"],
             period: float = PAPER_PARAMETERS["period"],
             max_penetration: float = PAPER_PARAMETERS["max_penetration"], letters=None,
             friction: float = PAPER_PARAMETERS["friction"], presliding: float = PAPER_PARAMETERS["presliding"],
             progress=None, surface: str | None = None) -> dict:
    """Recompute Table II for a sinusoidal texture, or in 3-D for an areal one.

    Parameters
    ----------
    stiffness : float
        kappa_0 (N/m), default 2000 (Section V-A).
    amplitude : float
        A (m), default 0.8 mm.
    period : float
        l (m), default 1 mm.
    max_penetration : float
        Depth bound of the analysed region (m), default 1 mm (d^z_max).
    letters : iterable of str, optional
        Algorithms to include; default W and every registered letter.
    friction : float
        F's friction coefficient mu, default 0.8.
    presliding : float
        F's presliding range d^x_max (m), default 1 mm. F's modulation depth is its
        default 0.8 (the paper's A = 0.8) and its d^z_max is ``max_penetration``.
    progress : callable, optional
        Called with each algorithm's letter before its row is computed.
    surface : {None, "egg-crate"}, optional
        ``"egg-crate"``: Table II in 3-D over h = A sin(2 pi x / l) sin(2 pi y / l), for
        the algorithms defined over surfaces (W, A, B, C, F, G). The loops are the paper's
        (Fig. 3, eq. 29) in the plane y = l/4, where the egg-crate's slice is the paper's
        sinusoid and its gradient has no y component, so their closed forms still hold;
        the random loops are polygons in space.

    Returns
    -------
    dict
        ``{"parameters": {...}, "rows": [{"algorithm", "name", "characteristic_number",
        "characteristic_number_closed_form", "characteristic_number_where",
        "characteristic_number_note", "loop_energy", "loop_energy_closed_form",
        "loop_path", "conservative", "max_abs_random_loop_energy", "continuous",
        "continuity_order", "paper": {...}, "agrees_with_paper": {...}}, ...]}``.
        Energies in J, positions in m. An unbounded characteristic number is ``inf``.

    Raises
    ------
    ParameterError
        If a parameter is out of range.
    """
    k0 = positive("stiffness", stiffness, "N/m")
    A = nonnegative("amplitude", amplitude, "m")
    l = positive("period", period, "m")
    dmax = positive("max_penetration", max_penetration, "m")
    friction = nonnegative("friction", friction)
    presliding = positive("presliding", presliding, "m")
    tex = Sinusoid(A, l)
    if surface not in (None, "egg-crate"):
        raise fail("surface", surface, "None or 'egg-crate'")
    order = list(ALGORITHMS) if letters is None else _letters(letters)
    if surface is not None:
        tex = SumOfGratings.egg_crate(A, l)
        order = [c for c in order if ALGORITHMS[c].surfaces] if letters is None else order
    algs = checked_algorithms(order, tex, k0, dmax, friction, presliding)
    rows = []
    for letter, alg in algs.items():
        if progress is not None:
            progress(letter)
        q = characteristic_number(alg, max_penetration=dmax)
        if surface is None:
            path, expected, source = paper_loop(alg, depth=dmax / 2 if letter in "GW" else None)
        else:  # the paper's loop in the plane y = l/4, where the egg-crate is the paper's sinusoid
            flat = checked_algorithms([letter], Sinusoid(A, l), k0, dmax, friction, presliding)[letter]
            path, expected, source = paper_loop(flat, depth=dmax / 2 if letter in "GW" else None)
            path = np.column_stack([path[:, 0], np.full(len(path), l / 4), path[:, 1]])
            source += ", in the plane y = l/4"
        e_loop = path_work(alg, path)
        cons = conservativity(alg, max_penetration=dmax)
        cont = continuity(alg, max_penetration=dmax)
        exp_cons, exp_cont = _EXPECTED.get(letter, (None, None))
        rows.append(
            {
                "algorithm": letter,
                "name": alg.name,
                "characteristic_number": q.value,
                "characteristic_number_closed_form": q.closed_form,
                "characteristic_number_where": list(q.where),
                "characteristic_number_note": q.note,
                "characteristic_number_paper_form": q.paper_form_value,
                "characteristic_number_extra": q.extra,
                "loop_energy": e_loop,
                "loop_energy_closed_form": expected,
                "loop_path": source,
                "conservative": cons.conservative,
                "almost_conservative": cons.almost,
                "max_abs_random_loop_energy": max((abs(e) for e in cons.random_loop_energies), default=0.0),
                "conservativity_tolerance": cons.tolerance,
                "continuous": cont.continuous,
                "continuity_order": cont.order,
                "paper": TABLE_II_CLAIMS[letter],
                "agrees_with_paper": {
                    "characteristic_number": _q_agrees(q.value, q.closed_form, q.extra),
                    "conservative": None if exp_cons is None else (
                        cons.almost if exp_cons == "almost" else cons.conservative == exp_cons),
                    "continuous": None if exp_cont is None else cont.continuous == exp_cont,
                },
            }
        )
    return {
        "parameters": {"stiffness": k0, "amplitude": A, "period": l, "max_penetration": dmax,
                       "friction": friction, "presliding": presliding, "texture": repr(tex),
                       "units": {"stiffness": "N/m", "amplitude": "m", "period": "m", "max_penetration": "m",
                                 "friction": "1", "presliding": "m"}},
        "rows": rows,
    }


def _q_agrees(value: float, closed: float | None, extra: dict | None = None):
    if extra and "paper_reported" in extra:
        return bool(math.isclose(value, extra["paper_reported"], rel_tol=0.05))
    if closed is None:
        return None
    return bool(math.isclose(value, closed, rel_tol=1e-6))
