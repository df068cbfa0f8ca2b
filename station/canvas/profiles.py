"""Paint profiles as data: XML files validated with lxml against ``profile.xsd``.

A profile (seed 8.4.5) is one file: ``<paper>`` (Worley preset = its texture, absorbency
``alpha``, capillary spread and capacity, sizing ``moist_threshold``, the diffusion
controller's paper share), ``<fluid>`` (viscosity, diffusion, evaporation, the air's
temperature and humidity, the canvas tilt), ``<numerics>``, ``<render>``, ``<palette>``
(pigments with Kubelka-Munk K and S, staining, granulation, density) and ``<brush>``
defaults. Every number attribute is one :class:`SimParams` field; one left out takes the
default. The built-in watercolor, gouache and ink profiles ship as
``station/data/profiles/*.xml``; a painter's own profiles live in
``$XDG_CONFIG_HOME/station/profiles/<name>.xml`` (``~/.config`` when unset). Built-in
names win over user files of the same name, so a bundled session always replays alike.

A file that is not well-formed, breaks the schema or holds an unusable value raises
:class:`CanvasInputError` naming the file, the line and the element.
"""

from __future__ import annotations

import dataclasses
import math
import re
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

from lxml import etree

from station import boundedio, paths
from station.canvas.errors import CanvasInputError
from station.canvas.palette import Palette, Pigment, default_palette
from station.canvas.params import BrushDefaults, Profile, SimParams

BUILTIN = ("watercolor", "gouache", "ink")
GROUPS: dict[str, tuple[str, ...]] = {
    "paper": ("alpha", "cap_diffusion", "eps_cap", "c_min", "c_max", "moist_threshold",
              "damp_ease", "damp_sat", "damp_exposure", "suspend_sat", "advance_height",
              "advance_grain",
              "advance_curvature",
              "paper_relief",
              "paper_shade", "block_paper", "block_fade",
              "fibre_wick", "fibre_dispersivity",
              "fibre_flow_max", "fibre_permeability", "fibre_gate_depth",
              "fibre_gate_pull"),
    "fluid": ("viscosity", "nu_w", "nu_p", "eps_shallow", "edge_evap", "flow_outward",
              "wet_blur", "rim_sharpness", "rim_onset", "rim_full", "wet_hold", "omega_h",
              "height_gain", "w_min", "w_max", "v_max",
              "surface_rate",
              "lift_gain",
              "w_dry_eps", "temperature", "humidity", "airflow", "tilt", "tilt_direction",
              "gravity", "standing_depth", "standing_nu_p", "standing_front_pull",
              "standing_front_dry"),
    "numerics": ("dt", "jacobi_iters", "tile_size", "tile_check"),
    "render": ("gouache_opaque", "gouache_white", "render_bands"),
}
"""Which element carries each :class:`SimParams` field."""
_INT_FIELDS = {f.name for f in dataclasses.fields(SimParams) if f.type in ("int", int)}
MAX_FILE_BYTES = 1 << 20
# No profile number is anywhere near this (the largest bundled ones are tens); beyond
# it a value is a typo or an attack, and float32 fields would overflow in the sim.
MAX_VALUE = 1e6
_SCHEMA_MSG = re.compile(r"Element '([^']+)'(?:, attribute '([^']+)')?: (.*)", re.S)


@lru_cache(maxsize=1)
def schema() -> etree.XMLSchema:
    """The shipped schema (``station/data/profiles/profile.xsd``)."""
    xsd = resources.files("station").joinpath("data", "profiles", "profile.xsd").read_bytes()
    return etree.XMLSchema(etree.fromstring(xsd))


def user_dir() -> Path:
    """Where a painter's own profiles live: ``$XDG_CONFIG_HOME/station/profiles``
    (:func:`station.paths.xdg_config_dir`)."""
    return paths.xdg_config_dir() / "profiles"


def _err(where: str, el: object, msg: str) -> CanvasInputError:
    line = getattr(el, "sourceline", None)
    tag = getattr(el, "tag", "profile")
    return CanvasInputError(f"element <{tag}>: {msg}", f"{where}:{line}" if line else where)


def _finite(text: str, key: str, el: etree._Element, where: str) -> float:
    """A finite number or an error naming the attribute (``float`` takes inf and nan,
    which the simulation would carry into every cell)."""
    try:
        v = float(text)
    except ValueError:
        raise _err(where, el, f"attribute {key}={text[:40]!r} is not a number") from None
    if not math.isfinite(v):
        raise _err(where, el, f"attribute {key}={text[:40]!r} is not a finite number")
    if abs(v) > MAX_VALUE:
        raise _err(where, el, f"attribute {key}={text[:40]!r} is out of range "
                              f"(at most {MAX_VALUE:g} in size)")
    return v


def _rgb(el: etree._Element, key: str, where: str) -> tuple[float, float, float]:
    vals = [_finite(x, key, el, where) for x in el.get(key).split()]
    if len(vals) != 3:
        raise _err(where, el, f"{key} needs 3 numbers")
    return vals[0], vals[1], vals[2]


def parse_profile(data: bytes, where: str) -> Profile:
    """The profile in the XML ``data`` (``where`` names it in error messages)."""
    root = _checked_root(data, where)
    params = _profile_params(root, where)
    defs = _profile_pigments(root, where)
    names = tuple(p.name for p in defs)
    if len({n.casefold() for n in names}) != len(names):
        raise _err(where, root.find("palette"), "a pigment is listed twice")
    brush = _profile_brush(root, names, where)
    desc = root.find("description")
    return Profile(name=root.get("name"), params=params, paper=root.find("paper").get("preset"),
                   renderer=root.get("renderer"), pigments=names, brush=brush,
                   description=(desc.text or "").strip() if desc is not None else "",
                   pigment_defs=tuple(defs), source=where)


def _checked_root(data: bytes, where: str) -> etree._Element:
    """The XML root of a profile, well-formed, without a DTD, valid against the schema."""
    if len(data) > MAX_FILE_BYTES:
        raise CanvasInputError(f"profile file larger than {MAX_FILE_BYTES} bytes", where)
    if re.search(rb"<!\s*(DOCTYPE|ENTITY)", data, re.IGNORECASE):
        # a DTD can define entities (billion laughs) and external references: a profile
        # never needs one
        raise CanvasInputError("a profile may not have a DOCTYPE or ENTITY declaration",
                               where)
    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=False,
                             load_dtd=False)
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as exc:
        line = exc.position[0] if exc.position else exc.lineno
        raise CanvasInputError(f"not well-formed XML: {exc.msg}", f"{where}:{line}") from None
    sch = schema()
    if not sch.validate(root):
        e = sch.error_log.last_error
        m = _SCHEMA_MSG.match(e.message)
        msg = e.message
        if m:
            attr = f" attribute {m.group(2)}" if m.group(2) else ""
            msg = f"element <{m.group(1)}>{attr}: {m.group(3)}"
        raise CanvasInputError(msg, f"{where}:{e.line}")
    return root


def _profile_params(root: etree._Element, where: str) -> SimParams:
    """The simulation parameters of the profile's groups (an error names the element)."""
    values: dict[str, Any] = {}
    owner: dict[str, etree._Element] = {}  # which element set each value
    for group in GROUPS:
        el = root.find(group)
        if el is None:
            continue
        for key, text in el.attrib.items():
            if key == "preset":
                continue
            v = _finite(text, key, el, where)
            if key in _INT_FIELDS:
                if v != int(v) or abs(v) > 1 << 31:
                    raise _err(where, el, f"attribute {key}={text[:40]!r} is not a whole number")
                v = int(v)
            values[key] = v
            owner[key] = el
    try:
        return SimParams(**values)
    except CanvasInputError as exc:
        msg = str(exc).removeprefix("params: ")
        el = next((owner[k] for k in owner if k in msg), root)
        raise _err(where, el, msg) from None


def _profile_pigments(root: etree._Element, where: str) -> list[Pigment]:
    """The palette: packaged pigments by name, or new ones with their coefficients."""
    known = default_palette()
    defs: list[Pigment] = []
    for el in root.find("palette").iterfind("pigment"):
        name = el.get("name")
        try:
            base: Pigment | None = known.get(name) if name in known else None
            if el.get("K") is None or el.get("S") is None:
                packaged = known.get(name)  # unknown name: "unknown pigment" error
                K, S = packaged.K, packaged.S
                spec = (packaged.K_spec, packaged.S_spec)
            else:
                K, S = _rgb(el, "K", where), _rgb(el, "S", where)
                # the packaged pigment's spectra while its RGB K, S are repeated; other
                # coefficients are a new pigment, which the spectral render upsamples
                same = base is not None and (base.K, base.S) == (K, S)
                spec = (base.K_spec, base.S_spec) if same and base is not None else ((), ())
            props = []
            for key, attr in (("staining", "beta"), ("granulation", "gamma"),
                              ("density", "delta")):
                v = el.get(key)
                if v is None and base is None:
                    raise _err(where, el, f"pigment {name!r} needs {key}")
                props.append(_finite(v, key, el, where) if v is not None else getattr(base, attr))
            defs.append(Pigment(name, K, S, props[0], props[1], props[2], *spec))
        except CanvasInputError as exc:
            if exc.where and exc.where.startswith(where):
                raise
            raise _err(where, el, str(exc).split(": ", 1)[-1]) from None
    return defs


def _profile_brush(root: etree._Element, names: tuple[str, ...], where: str) -> BrushDefaults:
    """The brush defaults (the first pigment when the profile names none)."""
    bel = root.find("brush")
    battrs: dict[str, Any] = {}
    if bel is not None:
        battrs = {k: (v if k == "pigment" else _finite(v, k, bel, where))
                  for k, v in bel.attrib.items()}
        if "pigment" in battrs and battrs["pigment"].casefold() not in {
                n.casefold() for n in names}:
            raise _err(where, bel, f"brush pigment {battrs['pigment']!r} is not in the palette")
    brush = BrushDefaults(**battrs)
    if bel is None or "pigment" not in battrs:
        brush = dataclasses.replace(brush, pigment=names[0])
    return brush


def load_profile_file(path: str | Path) -> Profile:
    """Read and check one profile file."""
    where = str(path)
    try:
        data = boundedio.read_bytes(path, boundedio.CAP_CONFIG, where)
    except OSError as exc:
        raise CanvasInputError(f"cannot read profile ({exc.strerror})", where) from None
    return parse_profile(data, where)


def _num(v: float | int) -> str:
    return str(v) if isinstance(v, int) else repr(float(v))


def profile_xml(prof: Profile) -> bytes:
    """The profile as an XML file :func:`parse_profile` reads back to an equal profile."""
    root = etree.Element("profile", name=prof.name, renderer=prof.renderer)
    etree.SubElement(root, "description").text = prof.description
    for group, fields in GROUPS.items():
        el = etree.SubElement(root, group)
        if group == "paper":
            el.set("preset", prof.paper)
        for f in fields:
            el.set(f, _num(getattr(prof.params, f)))
    pal = etree.SubElement(root, "palette")
    defs = prof.pigment_defs or tuple(default_palette().get(n) for n in prof.pigments)
    for p in defs:
        etree.SubElement(pal, "pigment", name=p.name, K=" ".join(_num(x) for x in p.K),
                         S=" ".join(_num(x) for x in p.S), staining=_num(p.beta),
                         granulation=_num(p.gamma), density=_num(p.delta))
    b = prof.brush
    etree.SubElement(root, "brush", radius=_num(b.radius), water=_num(b.water),
                     pigment_load=_num(b.pigment_load), pigment=b.pigment, amount=_num(b.amount))
    out: bytes = etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="utf-8")
    return out


def _builtin() -> dict[str, Profile]:
    out: dict[str, Profile] = {}
    for name in BUILTIN:
        res = resources.files("station").joinpath("data", "profiles", f"{name}.xml")
        prof = parse_profile(res.read_bytes(), f"station/data/profiles/{name}.xml")
        if prof.name != name:
            raise CanvasInputError(f"built-in profile file names {prof.name!r}", name)
        out[name] = prof
    return out


PROFILES: dict[str, Profile] = _builtin()
"""The built-in profiles, read from their files once at import."""

_user_cache: dict[str, tuple[float, Profile]] = {}


def user_profile(name: str) -> Profile | None:
    """The user profile ``name`` (re-read when its file changed), ``None`` if there is none."""
    if not name or "/" in name or name.startswith("."):
        return None
    path = user_dir() / f"{name}.xml"
    try:
        mtime = path.stat().st_mtime
    except OSError:
        return None
    hit = _user_cache.get(str(path))
    if hit is not None and hit[0] == mtime:
        return hit[1]
    prof = load_profile_file(path)
    if prof.name != name:
        raise CanvasInputError(f"the file names profile {prof.name!r}; it must be {name!r}",
                               str(path))
    _user_cache[str(path)] = (mtime, prof)
    return prof


def profile_names() -> list[str]:
    """Built-in names, then the user profiles' names (sorted)."""
    users: list[str] = []
    try:
        users = sorted(p.stem for p in user_dir().glob("*.xml") if p.stem not in PROFILES)
    except OSError:
        pass
    return [*PROFILES, *users]


def get_profile(name: str) -> Profile:
    """The profile called ``name``: built-in, else ``<user_dir>/<name>.xml``.

    Unknown names and bad files raise :class:`CanvasInputError`."""
    prof = PROFILES.get(name) if isinstance(name, str) else None
    if prof is None and isinstance(name, str):
        prof = user_profile(name)
    if prof is None:
        raise CanvasInputError(
            f"unknown profile {name!r} (known: {', '.join(profile_names())})", "--profile")
    return prof


def profile_palette(prof: Profile, base: Palette | None = None) -> Palette:
    """``base`` (the packaged palette by default) with the profile's own pigments added
    (a pigment the profile defines replaces the one of the same name)."""
    start = base if base is not None else default_palette()
    own = {p.name.casefold(): p for p in prof.pigment_defs}
    if all(p.name in start and start.get(p.name) == p for p in prof.pigment_defs):
        return start  # nothing new: keep the very same palette (and its order)
    kept = [own.pop(p.name.casefold(), p) for p in start]
    return Palette([*kept, *own.values()])
