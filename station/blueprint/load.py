"""Read a blueprint file: parse (lxml, no entities, no network), validate against the
shipped schema, apply ``--set ID.ATTR=VALUE`` overrides, build the model.

Every error is a :class:`BlueprintError` naming the file, line and element.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from pathlib import Path

from lxml import etree

from station import boundedio
from station.blueprint.model import (
    Action,
    Blueprint,
    BlueprintError,
    Component,
    Rule,
    Where,
    Wire,
    parse_duration,
)

COMPONENT_KINDS = ("bus", "driver", "haptic", "replay", "sim", "kiosk", "recorder", "gallery",
                   "calibration")
MAX_FILE_BYTES = 1 << 20


@lru_cache(maxsize=1)
def schema() -> etree.XMLSchema:
    """The blueprint schema shipped in the package (``blueprint.xsd``)."""
    text = resources.files("station.blueprint").joinpath("blueprint.xsd").read_bytes()
    return etree.XMLSchema(etree.fromstring(text, _parser()))


def _parser() -> etree.XMLParser:
    # A blueprint never pulls anything in: no DTD, no entities, no network.
    return etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False,
                           huge_tree=False, remove_comments=True)


def bundled(name: str) -> Path:
    """A bundled blueprint by name (``headless-demo``) or file name."""
    base = resources.files("station").joinpath("data", "blueprints")
    stem = name[:-4] if name.endswith(".xml") else name
    return Path(str(base.joinpath(f"{stem}.xml")))


def bundled_names() -> list[str]:
    base = resources.files("station").joinpath("data", "blueprints")
    return sorted(p.name[:-4] for p in base.iterdir() if p.name.endswith(".xml"))


def resolve_path(text: str) -> Path:
    """A file path, or the name of a bundled blueprint when no such file exists."""
    path = Path(text)
    if path.exists() or "/" in text:
        return path
    candidate = bundled(text)
    return candidate if candidate.exists() else path


def load(text_or_path: str, overrides: list[str] | None = None) -> Blueprint:
    """Read, validate and override a blueprint (see the module docstring)."""
    path = resolve_path(text_or_path)
    try:
        data = boundedio.read_bytes(path, MAX_FILE_BYTES, str(path))
    except OSError as exc:
        raise BlueprintError(f"cannot read ({exc.strerror})", str(path)) from None
    if len(data) > MAX_FILE_BYTES:
        raise BlueprintError(f"larger than {MAX_FILE_BYTES} bytes", str(path))
    return loads(data, str(path), overrides or [])


def loads(data: bytes, name: str, overrides: list[str] | None = None) -> Blueprint:
    try:
        root = etree.fromstring(data, _parser())
    except etree.XMLSyntaxError as exc:
        line = exc.lineno or 0
        raise BlueprintError(f"not well-formed XML: {exc.msg}", f"{name}:{line}") from None
    if root.getroottree().docinfo.doctype:
        raise BlueprintError("a blueprint has no DOCTYPE (no DTD, no entities)", f"{name}:1")
    if root.tag != "station":
        raise BlueprintError(f"the root element is <{root.tag}>, not <station>",
                             f"{name}:{root.sourceline}")
    _validate(root, name)
    for text in overrides or []:
        _override(root, text)
    _validate(root, name, overrides)
    return _model(root, name)


def _validate(root: etree._Element, name: str, overrides: list[str] | None = None) -> None:
    xsd = schema()
    try:
        if xsd.validate(root):
            return
    except etree.XMLSchemaValidateError as exc:
        raise BlueprintError(f"schema: cannot validate ({exc})", f"{name}:1") from None
    err = xsd.error_log.last_error  # libxml2 stops at the first problem of an element
    first = xsd.error_log[0] if len(xsd.error_log) else err
    msg = _short(first.message)
    where = f"{name}:{first.line}"
    if overrides:
        raise BlueprintError(f"{msg} (after --set {', '.join(overrides)})", where)
    raise BlueprintError(f"schema: {msg}", where)


def _short(message: str) -> str:
    """libxml2's message without its namespace braces, on one line."""
    return " ".join(message.replace("{http://www.w3.org/2001/XMLSchema}", "xs:").split())


def _override(root: etree._Element, text: str) -> None:
    target, sep, value = text.partition("=")
    ident, dot, attr = target.partition(".")
    where = f"--set {text}"
    if not sep or not dot or not ident or not attr:
        raise BlueprintError("must be ID.ATTRIBUTE=VALUE (e.g. sim.width=400)", where)
    found = [el for el in root if el.get("id") == ident]
    if not found:
        raise BlueprintError(f"no component with id {ident!r}", where)
    if attr in ("id",) or attr.startswith("{"):
        raise BlueprintError(f"{attr!r} cannot be overridden", where)
    if len(value) > 4096 or "\n" in value or "\x00" in value:
        raise BlueprintError("value must be one short line", where)
    if value:
        found[0].set(attr, value)
    elif attr in found[0].attrib:  # an empty value removes the attribute
        del found[0].attrib[attr]


def _where(el: etree._Element, name: str) -> Where:
    return Where(name, int(el.sourceline or 0), str(el.tag), el.get("id"))


def _model(root: etree._Element, name: str) -> Blueprint:
    components: list[Component] = []
    rules: list[Rule] = []
    description = ""
    for el in root:
        if not isinstance(el.tag, str):
            continue
        if el.tag == "description":
            description = " ".join((el.text or "").split())
        elif el.tag in COMPONENT_KINDS:
            wires = [Wire(r.get("interface"), r.get("from"), _where(r, name))
                     for r in el if r.tag == "requires"]
            attrs = {k: v for k, v in el.attrib.items() if not k.startswith("{")}
            ident = attrs.pop("id")
            components.append(Component(el.tag, ident, attrs, wires, _where(el, name)))
        elif el.tag == "on":
            rules.append(_rule(el, name))
    return Blueprint(name=root.get("name"), file=name, components=components, rules=rules,
                     description=description, user=root.get("user"))


def _rule(el: etree._Element, name: str) -> Rule:
    where = _where(el, name)
    after = el.get("after")
    after_s = parse_duration(after, str(where)) if after is not None else None
    event = el.get("event")
    if event == "idle" and not after_s:
        raise BlueprintError("an idle rule needs after=\"DURATION\" (> 0)", str(where))
    if event != "idle" and after is not None:
        raise BlueprintError(f"after= applies to idle rules only, not {event!r}", str(where))
    actions = tuple(Action(a.tag, dict(a.attrib), _where(a, name)) for a in el
                    if isinstance(a.tag, str))
    return Rule(event=event, after_s=after_s, component=el.get("component"),
                device=el.get("device"), actions=actions, where=where)
