"""Model files: haptex's JSON and HaTT's XML as published."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from .._validation import ParameterError, a_path, fail, out_file, whole
from .models import _ACC_UNITS, FORMAT, FORMAT_VERSION, ArmaModel, ModelSet

# ---------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------

MAX_FILE_BYTES = 64 * 2**20
"""Largest model file read (64 MiB; HaTT's largest are a few hundred kB)."""


def read_models(path) -> ModelSet:
    """Read a model set: haptex's own JSON (:meth:`ModelSet.write`) or HaTT's XML (:func:`read_hatt`).

    Parameters
    ----------
    path : str or os.PathLike
        The file; its content, not its name, says which format it is.

    Returns
    -------
    ModelSet

    Raises
    ------
    ParameterError
        If ``path`` is not a path (a str or os.PathLike, PEP 519), the file is missing, too
        large (:data:`MAX_FILE_BYTES`), of neither format, or
        its content is refused (the field, its value and what is allowed).
    """
    data = _read_bytes(path)
    head = data.lstrip()[:1]
    if head == b"<":
        return _parse_hatt(data, path)
    if head == b"{":
        return _parse_json(data, path)
    raise fail("path", str(path), "a model file: haptex's JSON (haptex fit writes one) or HaTT's XML")


def _read_bytes(path) -> bytes:
    p = a_path("path", path, "a model file's path")
    if not p.is_file():
        raise fail("path", str(path), "an existing model file")
    if p.stat().st_size > MAX_FILE_BYTES:
        raise fail("path", str(path), f"a model file of at most {MAX_FILE_BYTES // 2**20} MiB")
    return p.read_bytes()


def _parse_json(data: bytes, path) -> ModelSet:
    try:
        d = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise fail("path", str(path), f"valid JSON ({exc})") from None
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise fail("format", d.get("format") if isinstance(d, dict) else d, f"{FORMAT!r}")
    if d.get("version") != FORMAT_VERSION:
        raise fail("version", d.get("version"), f"{FORMAT_VERSION} (this release's); a newer haptex reads newer files")
    fs = d.get("sample_rate_hz")
    models = []
    raw = d.get("models")
    if not isinstance(raw, list):
        raise fail("models", raw, "a list of models")
    for k, m in enumerate(raw):
        if not isinstance(m, dict):
            raise fail(f"models[{k}]", m, "an object with speed_m_per_s, force_n, ar, ma, variance_m2_per_s4, gain")
        missing = [f for f in ("speed_m_per_s", "force_n", "ar", "ma", "variance_m2_per_s4", "gain") if f not in m]
        if missing:
            raise fail(f"models[{k}]", f"without {missing[0]}", "every field of a model (see the file formats page)")
        try:
            models.append(ArmaModel(m["ar"], m["ma"], m["variance_m2_per_s4"], m["gain"], fs, m["speed_m_per_s"],
                                    m["force_n"]))
        except (ParameterError, TypeError, ValueError) as exc:
            raise ParameterError(f"models[{k}]: {exc}") from None
    tri = d.get("triangles")
    return ModelSet(models, None if tri is None else np.asarray(tri, dtype=np.int64).reshape(-1, 3),
                    mu=d.get("mu"), name=d.get("name", ""))


_HATT_IGNORED = {
    "htmlPicture": "a picture of the material (a path on the authors' Windows machine)",
    "htmlLinuxPicture": "the same picture's path on Linux",
    "renderPicture": "the texture image HaTT's demo draws on its sphere",
    "DTpicture": "a picture of the triangulation (Windows path)",
    "LinuxDTpicture": "the same picture's path on Linux",
}
"""The tags of HaTT's files that :func:`read_hatt` ignores on purpose, with what they hold:
pictures for HaTT's own viewer, none of them part of the models."""

_SPEED_UNITS = {"mm/s": 1e-3, "m/s": 1.0}
_FORCE_UNITS = {"N": 1.0}


def read_hatt(path, *, acceleration_unit: str | None = None) -> ModelSet:
    """Read a model set in the Penn Haptic Texture Toolkit's XML format, as HaTT publishes it.

    Parameters
    ----------
    path : str or os.PathLike
        A HaTT model file (``Models_<material>.xml``; Culbertson, Lopez Delgado &
        Kuchenbecker 2014). HaTT's files are licensed for non-profit research without
        redistribution: haptex ships none; its tests write sets in the same layout.
    acceleration_unit : {"m/s^2", "g"}, optional
        The unit of the recorded acceleration the models were fitted to, for a file without
        ``<AccelUnits>`` (every published file has it: ``m/s^2``); the variances are scaled to
        (m/s²)². Given for a file whose ``<AccelUnits>`` says otherwise, it is refused.

    Returns
    -------
    ModelSet
        Speeds converted from the file's ``<SpeedUnits>`` (mm/s) to m/s, forces in N, its own
        triangles (``<tri>``, 1-based in the file), its ``mu`` (the material's kinetic
        friction coefficient), its ``SampleRate`` (Hz), named by its ``<material>``; its
        ``ignored`` lists the tags read past on purpose (:data:`_HATT_IGNORED`: pictures).

    Raises
    ------
    ParameterError
        If ``path`` is not a path (a str or os.PathLike, PEP 519), a tag is missing or not a
        number, a count (``numMod``, ``numTri``,
        ``numARCoeff``, ``numMACoeff``) disagrees with what it counts, a ``<tri>`` has other
        than three vertices or one out of range, ``maxSpeed``/``maxForce`` are not the lists'
        largest, ``mu`` is negative, a unit is not one HaTT uses, a model is unstable or not
        finite, its ``ARlsf`` or ``MAlsf`` disagree with its coefficients, or the XML declares
        entities (an entity-expansion bomb is refused by defusedxml before anything is
        expanded). The message names the tag, and the triangle's or model's number.

    Notes
    -----
    The layout of the 100 published files (checked against each of them; see the data-driven
    guide): ``<modelSet texture="N">`` holds ``material``, ``AccelUnits``, ``SpeedUnits``,
    ``ForceUnits``, ``SampleRate``, ``mu``, ``numMod``, ``numTri``, ``maxSpeed``, ``maxForce``,
    ``speedList`` and ``forceList`` (one ``<value>`` a model), **one** ``<tri type="array">``
    **element per triangle** (three ``<value>`` vertex numbers, 1-based), ``numARCoeff``,
    ``numMACoeff`` and one ``<model>`` a vertex with ``modNum``, ``ARcoeff``, ``MAcoeff``
    (each with its leading 1), ``ARlsf``, ``MAlsf`` (rad), ``var``, ``gain``, ``speedMod`` and
    ``forceMod``; and the picture paths of :data:`_HATT_IGNORED`. Tags beyond these are listed
    in ``ignored`` too.
    """
    unit = None
    if acceleration_unit is not None:
        unit = _ACC_UNITS.get(str(acceleration_unit).strip())
        if unit is None:
            raise fail("acceleration_unit", acceleration_unit, "'m/s^2' or 'g'")
    return _parse_hatt(_read_bytes(path), path, unit)


_HATT_READ = {"material", "AccelUnits", "SpeedUnits", "ForceUnits", "SampleRate", "mu", "numMod", "numTri",
              "maxSpeed", "maxForce", "speedList", "forceList", "tri", "numARCoeff", "numMACoeff", "model"}


def _parse_hatt(data: bytes, path, unit: float | None = None) -> ModelSet:
    import defusedxml.ElementTree as ET
    from defusedxml import DefusedXmlException

    try:
        root = ET.fromstring(data, forbid_dtd=True)
    except DefusedXmlException as exc:
        raise fail("path", str(path), f"XML without a DTD or entities (refused: {type(exc).__name__})") from None
    except ET.ParseError as exc:
        raise fail("path", str(path), f"well-formed XML ({exc})") from None
    if root.tag != "modelSet":
        raise fail("root tag", root.tag, "'modelSet' (a HaTT model file)")

    def child(el, tag, where):
        c = el.find(tag)
        if c is None:
            raise fail(f"{where}<{tag}>", "missing", "present (HaTT's layout)")
        return c

    def values(c, name):
        texts = [e.text or "" for e in c] if len(c) else [(c.text or "").replace(",", " ")]
        try:
            v = np.array([float(x) for t in texts for x in t.split()], dtype=float)
        except ValueError:
            raise fail(name, " ".join(texts).strip()[:40], "numbers") from None
        if not np.all(np.isfinite(v)):
            raise fail(name, np.round(v, 6).tolist() if v.size <= 8 else "non-finite values", "finite numbers")
        return v

    def numbers(el, tag, where):
        return values(child(el, tag, where), f"{where}<{tag}>")

    def number(el, tag, where):
        v = numbers(el, tag, where)
        if v.size != 1:
            raise fail(f"{where}<{tag}>", v, "one number")
        return float(v[0])

    def text(tag, default, allowed):
        c = root.find(tag)
        if c is None:
            return default
        t = (c.text or "").strip()
        if t not in allowed:
            raise fail(f"<{tag}>", t, " or ".join(repr(a) for a in allowed) + " (the units HaTT's files use)")
        return t

    acc = text("AccelUnits", None, tuple(_ACC_UNITS))
    if acc is not None and unit is not None and _ACC_UNITS[acc] != unit:
        raise fail("acceleration_unit", f"{unit:g} m/s^2", f"the file's own <AccelUnits> ({acc!r}), or left out")
    unit = _ACC_UNITS[acc] if acc is not None else (1.0 if unit is None else unit)
    v_unit = _SPEED_UNITS[text("SpeedUnits", "mm/s", tuple(_SPEED_UNITS))]
    text("ForceUnits", "N", tuple(_FORCE_UNITS))

    fs = number(root, "SampleRate", "")
    if not fs > 0:
        raise fail("<SampleRate>", fs, "a rate > 0 (Hz)")
    mu = number(root, "mu", "")
    if mu < 0:
        raise fail("<mu>", mu, "a kinetic friction coefficient >= 0")
    n_mod = number(root, "numMod", "")
    n_tri = number(root, "numTri", "")
    speeds = numbers(root, "speedList", "") * v_unit
    forces = numbers(root, "forceList", "")
    tri_els = root.findall("tri")
    if not tri_els:
        raise fail("<tri>", "missing", "present (HaTT's layout: one <tri> element per triangle)")
    tris = []
    for k, el in enumerate(tri_els):
        t = values(el, f"<tri> {k + 1}")
        if t.size != 3:
            raise fail(f"<tri> {k + 1}", t.tolist(), "three vertex indices (one <tri> element per triangle, as "
                       "HaTT's files have)")
        tris.append(t)
    tri = np.array(tris)
    model_els = root.findall("model")
    for tag, count, what, of in (("numMod", n_mod, len(model_els), "<model> elements"),
                                 ("numMod", n_mod, speeds.size, "<speedList> values"),
                                 ("numMod", n_mod, forces.size, "<forceList> values"),
                                 ("numTri", n_tri, len(tri), "<tri> elements")):
        if count != what:
            raise fail(f"<{tag}>", count, f"{what:g}, the count of its {of}")
    bad = (tri != np.round(tri)) | (tri < 1) | (tri > n_mod)
    if bad.any():
        k, j = divmod(int(np.argmax(bad)), 3)
        raise fail(f"<tri> {k + 1}", tri[k, j], f"vertex indices in [1, {n_mod:g}] (1-based)")
    for tag, lst in (("maxSpeed", speeds / v_unit), ("maxForce", forces)):
        if root.find(tag) is not None:
            given = number(root, tag, "")
            if lst.size and abs(given - lst.max()) > 1e-6 * max(1.0, abs(given)):
                raise fail(f"<{tag}>", given, f"the largest of its list ({lst.max():g})")
    orders = {}
    for tag in ("numARCoeff", "numMACoeff"):
        if root.find(tag) is not None:
            orders[tag] = number(root, tag, "")
    models = []
    for k, el in enumerate(model_els):
        where = f"<model> {k + 1}: "
        if el.find("modNum") is not None and number(el, "modNum", where) != k + 1:
            raise fail(f"{where}<modNum>", number(el, "modNum", where), f"{k + 1}, its place in the file")
        ar, ma = numbers(el, "ARcoeff", where), numbers(el, "MAcoeff", where)
        for tag, poly in (("numARCoeff", ar), ("numMACoeff", ma)):
            if tag in orders and poly.size - 1 != orders[tag]:
                raise fail(f"{where}<{'AR' if tag == 'numARCoeff' else 'MA'}coeff>", f"{poly.size} values",
                           f"{orders[tag]:g} coefficients after the leading 1 (<{tag}>)")
        s, f = number(el, "speedMod", where) * v_unit, number(el, "forceMod", where)
        if abs(s - speeds[k]) > 1e-9 * max(1.0, abs(s)) or abs(f - forces[k]) > 1e-9 * max(1.0, abs(f)):
            raise fail(f"{where}<speedMod>, <forceMod>", (s / v_unit, f), f"the set's lists' entry {k + 1}: "
                       f"{speeds[k] / v_unit:g}, {forces[k]:g}")
        try:
            m = ArmaModel(ar, ma, number(el, "var", where) * unit**2, number(el, "gain", where), fs, s, f)
        except ParameterError as exc:
            raise ParameterError(f"{where}{exc}") from None
        for tag, ours in (("ARlsf", m.ar_lsf), ("MAlsf", m.ma_lsf)):
            given = numbers(el, tag, where)
            if not _lsf_agree(given, ours, fs):
                raise fail(f"{where}<{tag}>", given, f"the LSF of its coefficients ({np.round(ours, 4).tolist()} rad, "
                           "or the same in Hz or as fractions of pi)")
        models.append(m)
    material = root.find("material")
    name = (material.text or "").strip() if material is not None else ""
    try:
        out = ModelSet(models, tri.astype(np.int64) - 1, mu=mu, name=name or Path(os.fspath(path)).stem)
    except ParameterError as exc:
        raise ParameterError(f"<modelSet>: {exc}") from None
    out.ignored = tuple(dict.fromkeys(c.tag for c in root if c.tag not in _HATT_READ))
    return out


def _lsf_agree(given: np.ndarray, ours: np.ndarray, fs: float) -> bool:
    if given.size != ours.size:
        return False
    if given.size == 0:
        return True
    g = np.sort(given)
    return any(np.allclose(g * s, ours, rtol=1e-3, atol=1e-4) for s in (1.0, np.pi, 2 * np.pi / fs))




# ---------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------


def write_hatt(models: ModelSet, path, *, texture: int = 1) -> Path:
    """Write a model set in the Penn Haptic Texture Toolkit's XML layout, for HaTT's renderer
    and the tools that read its library.

    Parameters
    ----------
    models : ModelSet
        The set (haptex's own, fitted by :func:`fit`, or one read from HaTT).
    path : str or os.PathLike
        File to write (``Models_<material>.xml``); its folder must exist.
    texture : int, optional
        The ``<modelSet texture="N">`` number (HaTT numbers its 100 materials; default 1).

    Returns
    -------
    pathlib.Path
        The file written: the tags and order of :func:`read_hatt`'s Notes (one ``<tri>``
        element a triangle, 1-based; speeds in mm/s to 12 digits, ``AccelUnits`` m/s^2,
        every other number with Python's shortest round-tripping representation where HaTT
        prints six decimals, so that :func:`read_hatt` gives the set back to rounding), ``mu`` the
        set's (0 when it has none). No picture paths: HaTT's own renderer shows a
        ``renderPicture`` beside the texture; add one by hand for it.

    Raises
    ------
    ParameterError
        If ``models`` is not a :class:`ModelSet` or has no triangles (a set on one line),
        ``texture`` is not a whole number >= 0, ``path`` is not a path (a str or os.PathLike,
        PEP 519) or its folder does not exist.
    """
    import xml.etree.ElementTree as ET  # writing: defusedxml guards parsing only

    if not isinstance(models, ModelSet):
        raise fail("models", type(models).__name__, "a ModelSet (haptex.datadriven.fit or read_models)")
    path = out_file("path", path)
    if len(models.triangles) == 0:
        raise fail("models", repr(models), "a set with triangles (a HaTT file holds its Delaunay triangulation "
                   "and HaTT interpolates over it; a set on one line of speeds or forces has none): "
                   "haptex's JSON (ModelSet.write) keeps it")
    texture = whole("texture", texture, 0)
    p, q = models.models[0].order

    def num(x) -> str:
        return repr(float(x))

    root = ET.Element("modelSet", texture=str(int(texture)))

    def one(tag, text, parent=root):
        ET.SubElement(parent, tag).text = text

    def lst(tag, values, parent=root, array=True):
        el = ET.SubElement(parent, tag, {"type": "array"} if array else {})
        for v in values:
            ET.SubElement(el, "value").text = v

    speeds_mm = [num(float(f"{s * 1e3:.12g}")) for s in models.speeds]  # 0.03 m/s as 30.0, not 30.00000000000001
    one("material", models.name or path.stem)
    one("AccelUnits", "m/s^2")
    one("SpeedUnits", "mm/s")
    one("ForceUnits", "N")
    one("SampleRate", num(models.sample_rate))
    one("mu", num(models.mu or 0.0))
    one("numMod", str(len(models.models)))
    one("numTri", str(len(models.triangles)))
    one("maxSpeed", max(speeds_mm, key=float))
    one("maxForce", num(models.forces.max()))
    lst("speedList", speeds_mm)
    lst("forceList", [num(f) for f in models.forces])
    for t in models.triangles:
        lst("tri", [str(int(v) + 1) for v in t])
    one("numARCoeff", str(p))
    one("numMACoeff", str(q))
    for k, (m, s_mm) in enumerate(zip(models.models, speeds_mm)):
        el = ET.SubElement(root, "model")
        one("modNum", str(k + 1), el)
        lst("ARcoeff", [num(c) for c in m.ar], el, False)
        lst("ARlsf", [num(c) for c in m.ar_lsf], el, False)
        lst("MAcoeff", [num(c) for c in m.ma], el, False)
        lst("MAlsf", [num(c) for c in m.ma_lsf], el, False)
        one("var", num(m.variance), el)
        one("gain", num(m.gain), el)
        one("speedMod", s_mm, el)
        one("forceMod", num(m.force), el)
    ET.indent(root, space="   ")
    path.write_bytes(ET.tostring(root, encoding="utf-8", xml_declaration=True) + b"\n")
    return path
