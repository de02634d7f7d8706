"""Numbers the documentation's computed pages show, computed by haptex at build time
(docs/conf.py renders the pages of ``COMPUTED`` as Jinja2 templates with these values)."""

from __future__ import annotations

import functools


def _g(value, digits: int = 4) -> str:
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, str):
        return value
    if value == float("inf"):
        return "unbounded"
    return f"{value:.{digits}g}"


@functools.lru_cache(maxsize=None)
def _table_ii():
    import haptex as hx

    t = hx.table_ii()
    rows = []
    for r in t["rows"]:
        q = r["characteristic_number"]
        rows.append({
            "letter": r["algorithm"],
            "name": r["name"],
            "q": _g(q),
            "q_paper": r["paper"]["characteristic_number"],
            "loop": _g(r["loop_energy"], 4) if r["loop_energy"] is not None else "–",
            "loop_closed": _g(r.get("loop_energy_closed_form"), 4),
            "conservative": "almost" if r.get("almost_conservative") else _g(r["conservative"]),
            "continuous": _g(r["continuous"]),
            "agrees": all(v for v in r["agrees_with_paper"].values() if v is not None),
        })
    return t["parameters"], rows


def _presets():
    from haptex import catalogue

    out = []
    for key, p in catalogue.presets().items():
        figs = []
        for name, f in p.figures.items():
            src = catalogue.sources().get(f.source, "") if f.source else ""
            figs.append({"name": name, "written": f.written or _g(f.value), "status": f.status,
                         "source": src, "note": f.note})
        out.append({"key": key, "label": p.label, "model": p.model, "figures": figs})
    return out


def _hands():
    from haptex import catalogue

    out = []
    for key, h in catalogue.hands().items():
        out.append({"key": key, "label": h.label, "mass": _g(h.mass), "damping": _g(h.damping),
                    "stiffness": _g(h.stiffness),
                    "status": ", ".join(sorted({f.status for f in h.figures.values()})) or "–"})
    return out


def _limits():
    """Each preset's wall limits at the home pose (N/m), and what its rated figure implies."""
    from haptex import catalogue
    from haptex.limits import wall_limits

    out = []
    for key, p in catalogue.presets().items():
        dev = p.device()
        w = wall_limits(dev, "light-touch", preset=p)
        rows = {lim.key: lim.value for lim in w.limits}
        late = wall_limits(p.device(delay=1), "light-touch").stable
        out.append({"key": key, "rate": _g(1 / dev.period), "corollary_1": _g(rows["corollary_1"], 3),
                    "colgate_schenkel": _g(rows["colgate_schenkel"], 3), "abbott_okamura": _g(rows["abbott_okamura"], 3),
                    "encoder": _g(rows.get("encoder"), 3), "device": _g(rows["device"], 3),
                    "hand": _g(w.stable, 4), "delay_1": _g(late, 4), "rated": _g(p.rated_stiffness, 4),
                    "ratio": _g(w.rated_ratio, 2), "grip": _g(w.rated_hand_damping, 2), "gap": bool(p.rated_gap)})
    return out


def _registry():
    from haptex.algorithms import ALGORITHMS

    return [{"letter": k, "name": getattr(cls, "name", "") or (cls.__doc__ or "").strip().splitlines()[0],
             "parameters": ", ".join(getattr(cls, "parameters", ())) or "–",
             "textured": _g(bool(getattr(cls, "textured", True)))} for k, cls in ALGORITHMS.items()]


def context(docname: str) -> dict:
    """The values a computed page may use."""
    import haptex

    ctx = {"version": haptex.__version__}
    if docname in ("explanation/paper", "explanation/algorithms"):
        params, rows = _table_ii()
        ctx.update(parameters=params, rows=rows, registry=_registry())
    if docname == "explanation/validation":
        ctx.update(modules=_validation())
    if docname == "guides/devices-and-stability":
        rows = _limits()
        grips = [float(r["grip"]) for r in rows if r["grip"] != "–"]
        ctx.update(limits=rows, by_key={r["key"]: r for r in rows}, grip_low=_g(min(grips), 2),
                   grip_high=_g(max(grips), 2))
    if docname == "reference/presets":
        ctx.update(presets=_presets(), hands=_hands())
    if docname == "guides/data-driven-textures":
        ctx.update(vib=_vibration_stabilisers())
    return ctx


def _vibration_stabilisers():
    """The vibration under each stabiliser (haptex.experiments.vibration_under_stabilisers), as
    the guide's table shows it."""
    from haptex.experiments import vibration_under_stabilisers

    d = vibration_under_stabilisers()
    rows = [{"name": r["name"], "vib_mw": _g(r["vibration_power"] * 1e3, 3), "port_mw": _g(r["port_power"] * 1e3, 3),
             "felt_rms": _g(r["felt_rms"], 3), "felt": f"{r['felt']:.3g}", "alone": f"{r['felt_alone']:.3g}",
             "shape": _g(r["shape_db"], 3), "active": r["active"], "cut": r["cut"]} for r in d["rows"]]
    by = {r["name"]: r for r in d["rows"]}
    return {"rows": rows, "device": d["device"], "stiffness": _g(d["stiffness"], 4),
            "pc": by["passivity controller"]["label"], "by": by}


def _validation():
    """Each test module's own statement of what it checks against what (its docstring's first
    paragraph) and how many tests it holds: read from the test files by this build."""
    import ast
    from pathlib import Path

    rows = []
    for path in sorted((Path(__file__).resolve().parent.parent / "tests").glob("test_*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        doc = ast.get_docstring(tree) or ""
        first = " ".join(doc.split("\n\n")[0].split()) if doc else "(no module docstring: see its tests' own)"
        count = sum(isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and n.name.startswith("test_")
                    for n in ast.walk(tree))
        rows.append({"module": path.name, "about": first.replace("|", "/"), "tests": count})
    return rows
