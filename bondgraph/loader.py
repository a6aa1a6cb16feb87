"""Load and validate a hybrid bond graph from YAML (see docs/model-format.md).

``yaml.safe_load`` semantics (the safe loader's node tree is used to find line numbers and
duplicate keys); every expression goes through :func:`bondgraph.expressions.parse_expression`.
Every mistake raises :class:`ModelError` naming the file, the key and (where known) the line.

The bond graph is read from the physical sections. The monitor's settings in the same file
(``thresholds``, ``diagnosis``, and the ``bounds``/``failure`` of each fault) are no physics: they are
accepted here and read by :mod:`fdi.config` through the same :class:`Document`, so both readers
give the same one-line messages.
"""
from __future__ import annotations

import keyword
import math
import os
import re
import stat
import unicodedata
from collections import ChainMap
from dataclasses import dataclass, replace
from itertools import product
from pathlib import Path
from typing import Any, Mapping

import sympy as sp
import yaml

from .errors import ModelError
from .expressions import MAX_CONSTANT, ExpressionError, left_domain, parse_expression
from .model import (LAW_VARIABLES, ELEMENT_KINDS, FAULT_KINDS, JUNCTION_KINDS, SENSOR_KINDS, SOURCE_KINDS,
                    TWO_PORT_KINDS, Bond, Element, Fault, Input, Junction, Model, Mode, Parameter,
                    Sensor, t)
from .laws import STORAGE_KEYS
from .names import look_alike, same_name, skeleton
from .units import UnitError, check_unit

MONITOR_KEYS = {"thresholds", "diagnosis"}      # read by fdi.config, not by the bond graph
MONITOR_FAULT_KEYS = {"bounds", "failure"}      # ditto, in each fault
MAX_NAME = 200                                   # characters of a model's name
_TOP_KEYS = {"name", "description", "reference", "parameters", "definitions", "inputs", "modes",
             "elements", "junctions", "sensors", "bonds", "faults", "data", "initial"} | MONITOR_KEYS
_RESERVED = {"t"}
FAULT_EFFECTS = ("gain", "bias", "stuck")   # how a sensor or source fault acts: beta x signal, signal + b, frozen
OFF_SEMANTICS = ("all", "outputs")   # what a switched-off controlled junction holds at zero
MAX_TIME = 1.0e6             # s: a time beyond 11 days in a model file is a typing error


class _Ctx:
    """File name and line map shared by the validation helpers."""

    def __init__(self, path: str, lines: Mapping[tuple, int]) -> None:
        self.path = path
        self.lines = lines

    def error(self, where: tuple, message: str) -> ModelError:
        line = None
        for k in range(len(where), 0, -1):
            if where[:k] in self.lines:
                line = self.lines[where[:k]]
                break
        return ModelError(message, file=self.path, where=".".join(str(w) for w in where), line=line)


@dataclass(frozen=True)
class Document:
    """A model file read safely: its plain data and the line of each key. Readers of its sections
    validate through it, so every message names the file, the key and the line the same way.

    >>> doc = read_document_text("thresholds: {ARR1: 0.5}\\n", "m.yaml")
    >>> doc.number(doc.data["thresholds"]["ARR1"], ("thresholds", "ARR1"), "threshold", above=0)
    0.5
    >>> doc.number(-1, ("thresholds", "ARR1"), "threshold", above=0)
    Traceback (most recent call last):
    ...
    bondgraph.errors.ModelError: m.yaml:1: thresholds.ARR1: threshold must be more than 0, got -1
    """
    path: str
    data: dict
    lines: Mapping[tuple, int]

    @property
    def _ctx(self) -> "_Ctx":
        return _Ctx(self.path, self.lines)

    def error(self, where: tuple, message: str) -> ModelError:
        """A ModelError for the key at ``where`` (a path of keys), with its line when known."""
        return self._ctx.error(where, message)

    def mapping(self, value: Any, where: tuple, required: bool = False) -> dict:
        """``value`` as a mapping of name: settings ({} when absent and not ``required``)."""
        return _mapping(self._ctx, value, where, required)

    def spec(self, value: Any, where: tuple, allowed: set[str]) -> dict:
        """``value`` as a mapping whose keys are all in ``allowed``."""
        return _spec(self._ctx, value, where, allowed)

    def number(self, value: Any, where: tuple, what: str, **limits) -> float:
        """``value`` as a finite number within ``limits`` (see :func:`_number`)."""
        return _number(self._ctx, value, where, what, **limits)

    def ref(self, value: Any, where: tuple, what: str) -> str:
        """``value`` as one name of something defined elsewhere in the file."""
        return _ref(self._ctx, value, where, what)


MAX_BYTES = 1 << 20          # a model file: the CyCab's is 8 kB
MAX_NODES = 200_000          # YAML nodes once aliases are expanded (an alias bomb is refused before expansion)
MAX_NESTING = 64             # levels of YAML nesting


def load_model(path: str | Path) -> Model:
    """Read a model file; raise ModelError with a one-line message on any problem."""
    return model_from_document(read_document(path))


def load_model_text(text: str, path: str = "<model>") -> Model:
    """A model from YAML text (``path`` is only used in messages)."""
    return model_from_document(read_document_text(text, path))


def model_from_document(doc: Document) -> Model:
    """The bond graph of a read model file (its physical sections)."""
    return _build_model(doc.data, doc._ctx)


def _named_fifo(path: Path) -> bool:
    """A FIFO in a file system, not the pipe of a process substitution (``<(cat m.yaml)``, reached
    through /dev/fd: its open never waits)."""
    try:
        return stat.S_ISFIFO(os.stat(path).st_mode) and "pipe:[" not in os.path.realpath(path)
    except (OSError, ValueError):
        return False


def read_document(path: str | Path) -> Document:
    """Read a model file safely (at most 1 MB of UTF-8 YAML, measured before it is constructed)."""
    if isinstance(path, str) and ("\n" in path or "\r" in path) and not Path(path).exists():
        # YAML text given where a path goes (the message printed the text as the file's name)
        raise ModelError("text with line ends, not a file name; give the path of the model file, or read the text "
                         "with bondgraph.loader.load_model_text", file="<model>")
    p = Path(path)
    try:
        if p.is_dir():
            raise ModelError("is a folder; give the model's YAML file", file=str(path))
        if _named_fifo(p):                          # open() would wait for a writer that may never come
            raise ModelError(f"a named FIFO; give the model as a regular file (or as <(cat {path}))", file=str(path))
        with p.open("rb") as fh:
            raw = fh.read(MAX_BYTES + 1)
    except OSError as exc:
        raise ModelError(f"cannot read model file ({exc.strerror})", file=str(path)) from None
    if len(raw) > MAX_BYTES:
        raise ModelError(f"larger than {MAX_BYTES >> 20} MB; a model file is a few kB of YAML", file=str(path))
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ModelError(f"not UTF-8 text (byte {exc.start}); save the file as UTF-8", file=str(path)) from None
    return read_document_text(text, str(path))


def read_document_text(text: str, path: str = "<model>") -> Document:
    """Parse model YAML given as text (``path`` is only used in messages). Only the safe loader's
    tags; the document is composed once, measured (size with aliases expanded, nesting, recursive
    aliases, keys) and only then constructed."""
    if len(text) > MAX_BYTES:
        raise ModelError(f"larger than {MAX_BYTES >> 20} MB; a model file is a few kB of YAML", file=path)
    deep = _deep_line(text)
    if deep is not None:      # before any parser: PyYAML's takes seconds to reach its recursion limit
        raise ModelError(f"YAML nested more than {MAX_NESTING} levels deep", file=path, line=deep)
    loader = None
    try:
        loader, node = _compose(text.lstrip("\ufeff"))
        if node is None:
            raise ModelError("the file is empty; see docs/model-format.md for the layout", file=path)
        data = _plain(loader, node, path) if "&" not in text else _GENERAL
        if data is _GENERAL:
            _measure(node, path)
        lines: dict[tuple, int] = {}
        _index_lines(node, (), lines, path)
        if data is _GENERAL:
            try:
                data = loader.construct_document(node)
            except (ValueError, TypeError, AttributeError, OverflowError):   # a YAMLError is none of these
                raise _misfit(loader, node, path) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark else None
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        if "could not determine a constructor" in str(exc):
            problem = "a YAML tag (!!...) outside plain data; remove it"
        raise ModelError(f"not valid YAML: {problem}", file=path, line=line) from None
    except RecursionError:
        raise ModelError(f"YAML nested more than {MAX_NESTING} levels deep", file=path) from None
    finally:
        if loader is not None:
            loader.dispose()
    if not isinstance(data, dict):
        raise _Ctx(path, lines).error((), "the top level must be a mapping with keys such as parameters, elements, "
                                          "bonds")
    return Document(path, data, lines)


C_PARSER_BYTES = 32 << 10   # from this size on, libyaml's parser where PyYAML has it


def _compose(text: str) -> tuple[yaml.SafeLoader, yaml.Node | None]:
    """The safe loader of ``text`` and its composed document. PyYAML's own loader (its reader
    refuses control characters); for a large text with nothing that reader refuses, the same
    loader on libyaml's C parser, about 10 times faster (a 10 000-element chain, 0.9 MB: 3.5 s
    in the pure parser): the same tags, resolvers and constructors, the same node tree. A text
    the C parser refuses is composed again by the pure loader, so that messages stay its own."""
    if len(text) >= C_PARSER_BYTES and getattr(yaml, "__with_libyaml__", False) \
            and not yaml.reader.Reader.NON_PRINTABLE.search(text) and _flow_depth(text) <= MAX_NESTING:
        loader = yaml.CSafeLoader(text)
        try:
            return loader, loader.get_single_node()
        except yaml.YAMLError:
            loader.dispose()
    loader = yaml.SafeLoader(text)
    try:
        return loader, loader.get_single_node()
    except BaseException:
        loader.dispose()
        raise


_FLOW_TOKENS = re.compile(r'"(?:[^"\\\n]|\\.)*"|\'(?:[^\'\n]|\'\')*\'|(?:^|(?<=\s))#[^\n]*|[\[\]{}\n]')


def _deep_line(text: str) -> int | None:
    """The line where ``[`` and ``{`` nest deeper than MAX_NESTING, quoted strings and comments
    skipped; None when they do not. A flow collection nested 5 000 deep took the pure parser 2 s
    (12 s through the command) to refuse; this scan takes milliseconds. It is not
    :func:`_flow_depth`, which answers another question: whether libyaml's unchecked recursion is
    safe, by a bound that counts quoted brackets too (a quote this scan misreads must not send a
    deep text to C)."""
    depth, line = 0, 1
    for m in _FLOW_TOKENS.finditer(text):
        c = m.group()
        if c == "\n":
            line += 1
        elif c in "[{":
            depth += 1
            if depth > MAX_NESTING:
                return line
        elif c in "]}":
            depth = max(0, depth - 1)
        else:
            line += c.count("\n")
    return None


def _flow_depth(text: str) -> int:
    """An upper bound of the nesting of ``[`` and ``{`` in ``text`` (quotes not told apart). libyaml
    composes nested nodes by C recursion, unchecked: deeper texts go to the pure parser, which
    refuses them in a message. (Nesting by indentation needs d^2/2 bytes for depth d: at most
    about 1 450 levels in a file of MAX_BYTES.)"""
    depth = deepest = 0
    for c in re.sub(r"[^\[\]{}]+", "", text):
        depth += 1 if c in "[{" else -1
        deepest = max(deepest, depth)
    return deepest


def _measure(root: yaml.Node, path: str) -> None:
    """Refuse a document that is too big once its aliases are expanded (a "billion laughs" of a
    few hundred bytes), nested too deeply, or that refers to itself (a recursive alias). Each
    distinct node is visited once: sizes are memoised, so the check itself stays small."""
    size: dict[int, int] = {}
    open_: set[int] = set()

    def visit(node: yaml.Node, depth: int) -> int:
        key = id(node)
        if key in size:
            return size[key]
        if key in open_:
            raise ModelError("a recursive YAML alias (an anchor used inside itself); write the data out",
                             file=path, line=node.start_mark.line + 1)
        if depth > MAX_NESTING:
            raise ModelError(f"YAML nested more than {MAX_NESTING} levels deep", file=path,
                             line=node.start_mark.line + 1)
        open_.add(key)
        children: list = []
        if isinstance(node, yaml.MappingNode):
            children = [n for pair in node.value for n in pair]
        elif isinstance(node, yaml.SequenceNode):
            children = node.value
        total = 1 + sum(visit(c, depth + 1) for c in children)
        open_.discard(key)
        if total > MAX_NODES:
            raise ModelError(f"the YAML expands to more than {MAX_NODES} values (aliases counted each time "
                             "they are used); a model is far smaller", file=path, line=node.start_mark.line + 1)
        size[key] = total
        return total
    visit(root, 0)


_GENERAL = object()       # _plain's answer for a document left to PyYAML's constructor


class _General(Exception):
    """Raised inside :func:`_plain` at a node it leaves to PyYAML's constructor."""

_PLAIN_SCALARS = frozenset(f"tag:yaml.org,2002:{t}" for t in ("null", "bool", "int", "float", "timestamp", "binary"))
_STR, _MAP, _SEQ = "tag:yaml.org,2002:str", "tag:yaml.org,2002:map", "tag:yaml.org,2002:seq"


def _plain(loader: yaml.SafeLoader, root: yaml.Node, path: str) -> Any:
    """The document as ``loader.construct_document`` builds it, for a text without anchors (so
    without aliases: no node is shared or refers to itself), its size and nesting checked on the
    way as :func:`_measure` checks them (the same error at the same node): one walk for the two
    (a 10 000-element chain: 0.95 s measured and constructed, now 0.3 s). Plain maps, lists and
    the safe loader's scalars only; for anything else (a merge key, a set, another tag, a value
    its tag does not fit) ``_GENERAL``: the caller measures, indexes and constructs as PyYAML
    does, in that order, and its messages stay its own."""
    scalars = loader.yaml_constructors

    def build(node: yaml.Node, depth: int) -> tuple[Any, int]:
        """The node's value and its number of nodes; the limits as :func:`_measure` applies them
        (nesting on the way down, size once a node's subtree is counted: the same node named)."""
        if depth > MAX_NESTING:
            raise ModelError(f"YAML nested more than {MAX_NESTING} levels deep", file=path,
                             line=node.start_mark.line + 1)
        tag, size = node.tag, 1
        if isinstance(node, yaml.ScalarNode) and tag == _STR:
            value: Any = node.value
        elif isinstance(node, yaml.ScalarNode) and tag in _PLAIN_SCALARS:
            try:
                value = scalars[tag](loader, node)
            except Exception:                        # a value its tag does not fit: PyYAML's path says
                raise _General from None             # so, after the checks that come first there
        elif isinstance(node, yaml.MappingNode) and tag == _MAP:
            value = {}
            for key, item in node.value:
                if not isinstance(key, yaml.ScalarNode) or key.tag not in _PLAIN_SCALARS and key.tag != _STR:
                    raise _General
                k, n = build(key, depth + 1)             # the key first, as _measure visits it
                value[k], m = build(item, depth + 1)
                size += n + m
        elif isinstance(node, yaml.SequenceNode) and tag == _SEQ:
            value = []
            for item in node.value:
                v, n = build(item, depth + 1)
                value.append(v)
                size += n
        else:
            raise _General
        if size > MAX_NODES:
            raise ModelError(f"the YAML expands to more than {MAX_NODES} values (aliases counted each time "
                             "they are used); a model is far smaller", file=path, line=node.start_mark.line + 1)
        return value, size

    try:
        return build(root, 0)[0]
    except _General:
        return _GENERAL


def _misfit(loader: yaml.SafeLoader, root: yaml.Node, path: str) -> ModelError:
    """The error of a value its tag does not fit (``!!int x``, ``!!timestamp 'x'``: PyYAML's
    constructors raise plain Python errors there), naming the first such value's line."""
    stack = [root]
    while stack:
        node = stack.pop()
        if isinstance(node, yaml.ScalarNode) and node.tag in _PLAIN_SCALARS:
            try:
                loader.yaml_constructors[node.tag](loader, node)
            except Exception:
                kind = node.tag.rsplit(":", 1)[-1]
                line = node.start_mark.line + 1
                if kind == "int" and len(node.value) > 100 and re.fullmatch(r"[-+]?[0-9_]+", node.value):
                    # (an integer of thousands of digits: Python's conversion limit, no tag written)
                    return ModelError(f"not valid YAML: an integer of {len(node.value)} digits; a model's numbers "
                                      f"are floats: write it as 1.0e+300 or less", file=path, line=line)
                return ModelError(f"not valid YAML: '{node.value[:30]}' is no {kind}; write one or remove its "
                                  f"!!{kind} tag", file=path, line=line)
        elif isinstance(node, yaml.MappingNode):
            stack.extend(n for pair in reversed(node.value) for n in reversed(pair))
        elif isinstance(node, yaml.SequenceNode):
            stack.extend(reversed(node.value))
    return ModelError("not valid YAML: a value its tag does not fit; remove the tag", file=path)


_INF = re.compile(r"[-+]?\.(inf|Inf|INF)")


def _index_lines(node: yaml.Node, where: tuple, lines: dict[tuple, int], path: str) -> None:
    lines[where] = node.start_mark.line + 1
    if isinstance(node, yaml.ScalarNode) and node.tag.endswith(":float") and not _INF.fullmatch(node.value):
        try:
            big = math.isinf(float(node.value.replace("_", "")))
        except ValueError:
            big = False
        if big:
            raise ModelError(f"the number {node.value[:30]} is beyond the range of a double (1.8e308); "
                             "write .inf for infinity", file=path, where=".".join(str(w) for w in where),
                             line=node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, int] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                raise ModelError("a key must be a plain name or number, not a list or mapping", file=path,
                                 where=".".join(str(w) for w in where), line=key_node.start_mark.line + 1)
            key = key_node.value
            if key_node.tag.endswith(":int"):
                if not re.fullmatch(r"[-+]?[0-9]+", key):
                    raise ModelError(f"write '{key}' as a plain decimal integer (YAML reads it as "
                                     "hexadecimal, octal or base 60)", file=path,
                                     where=".".join(str(w) for w in where + (key,)), line=key_node.start_mark.line + 1)
                key = int(key)
            if key in seen:
                raise ModelError(
                    f"duplicate key '{key}' (first at line {seen[key]}); give each entry a unique name",
                    file=path, where=".".join(str(w) for w in where + (key,)),
                    line=key_node.start_mark.line + 1)
            seen[key] = key_node.start_mark.line + 1
            lines[where + (key,)] = key_node.start_mark.line + 1
            _index_lines(value_node, where + (key,), lines, path)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _index_lines(item, where + (i,), lines, path)


# ---------------------------------------------------------------- helpers

def _mapping(ctx: _Ctx, data: Any, where: tuple, required: bool = False) -> dict:
    if data is None:
        if required:
            raise ctx.error(where, "missing; see docs/model-format.md")
        return {}
    if not isinstance(data, dict):
        raise ctx.error(where, f"must be a mapping of name: settings, got {type(data).__name__}")
    for key in data:     # YAML 1.1 reads unquoted yes/no/on/off/true/false as booleans, ~ and null as None
        if isinstance(key, bool) or key is None:
            words = {True: "yes, on or true", False: "no, off or false", None: "~ or null"}[key]
            raise ctx.error(where, f"a name reads as {key} in YAML ({words} unquoted): quote it ('off') or "
                                   "choose another name" if key is False else
                            f"a name reads as {key} in YAML ({words} unquoted): quote it or choose another name")
    return data


def _spec(ctx: _Ctx, data: Any, where: tuple, allowed: set[str]) -> dict:
    if not isinstance(data, dict):
        raise ctx.error(where, "must be a mapping of settings (for example {type: R, parameter: R1})")
    for key in data:
        if key not in allowed:
            split = data[key] is None and any(isinstance(v, str) for v in data.values())
            hint = ("; a comma inside unquoted text in { } starts a new key: quote the text "
                    "(description: \"a, b\")" if split else "")
            raise ctx.error(where + (key,), f"unknown key '{key}' (allowed: {', '.join(sorted(allowed))}){hint}")
    return data


def _name(ctx: _Ctx, name: Any, where: tuple) -> str:
    if not isinstance(name, str) or not name.isidentifier():
        raise ctx.error(where, f"name '{name}' must be an identifier (letters, digits, _; not starting with a digit)")
    if name in _RESERVED or keyword.iskeyword(name):
        raise ctx.error(where, f"name '{name}' is reserved (time 't' and Python keywords); choose another")
    return name


def _number(ctx: _Ctx, value: Any, where: tuple, what: str, *, infinite: bool = False, minimum: float | None = None,
            above: float | None = None, maximum: float | None = None, integer: bool = False) -> float:
    """A number where the model needs one: never NaN; infinite only where ``infinite`` (a leakage
    resistance of a healthy part); at least ``minimum``, more than ``above``, at most ``maximum``."""
    number = None
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        try:
            number = float(value)
        except OverflowError:           # an integer literal of over 308 digits (YAML reads it exactly)
            raise ctx.error(where, f"{what} {str(value)[:12]}... ({len(str(abs(value)))} digits) is beyond the range "
                                   f"of a double (1.8e308); give it in SI units as a float (1e300)"
                                   f"{', or .inf for infinity' if infinite else ''}") from None
    elif isinstance(value, str):
        try:
            number = float(value)
        except ValueError:
            pass
    if number is None:
        hint = " (use .inf for infinity)" if infinite else ""
        raise ctx.error(where, f"{what} must be a number{hint}, got {_shown(value)}")
    if math.isnan(number):
        raise ctx.error(where, f"{what} is NaN; give a number")
    if math.isinf(number) and isinstance(value, str) and not re.fullmatch(r"[-+]?\.?inf(inity)?", value.strip(), re.I):
        raise ctx.error(where, f"{what} {value[:30]} is beyond the range of a double (1.8e308)"
                               + ("; write .inf for infinity" if infinite else "; give a finite number"))
    if math.isinf(number) and not infinite:
        raise ctx.error(where, f"{what} must be finite, got {value}")
    if integer and number != int(number):
        raise ctx.error(where, f"{what} must be a whole number, got {value}")
    if minimum is not None and number < minimum:
        raise ctx.error(where, f"{what} must be at least {minimum:g}, got {value}")
    if above is not None and not number > above:
        raise ctx.error(where, f"{what} must be more than {above:g}, got {value}")
    if maximum is not None and number > maximum:
        raise ctx.error(where, f"{what} must be at most {maximum:g}, got {value}")
    return number


def _shown(value: Any) -> str:
    """A value as a message quotes it: a list or mapping by its kind, text cut short."""
    if isinstance(value, (list, dict)):
        return f"a {'list' if isinstance(value, list) else 'mapping'}"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _ref(ctx: _Ctx, value: Any, where: tuple, what: str) -> str:
    """The name of something defined elsewhere in the file (a parameter, input, sensor, mode,
    junction or data column): one plain name, not a list or a mapping."""
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise ctx.error(where, f"{what} must be one name, got {_shown(value)}")
    return str(value)


def _meant(name: str, names) -> str:
    """' (did you mean ...)' where a defined name looks like ``name`` (Greek or Cyrillic letters
    drawn as Latin ones), with the characters that differ; else ''."""
    key = skeleton(name)
    other = next((n for n in names if n != name and skeleton(n) == key), None)
    return "" if other is None else f" (did you mean '{other}'? {look_alike(name, other)})"


def _expr(ctx: _Ctx, text: Any, where: tuple, symbols: Mapping[str, sp.Expr]) -> sp.Expr:
    try:
        return parse_expression(text, symbols)
    except ExpressionError as exc:
        raise ctx.error(where, str(exc)) from None


_VAR_WORDS = {"e": "its effort", "f": "its flow", "q": "its displacement", "p": "its momentum"}


def _law(ctx: _Ctx, text: Any, where: tuple, kind: str, law: str, params: Mapping[str, sp.Expr]) -> sp.Expr:
    """An element's constitutive law ``law`` (effort, flow, displacement or momentum), written in
    its one local variable (:data:`_LAW_VARS`); another law variable in it is named as such, with
    the key that takes a law in that variable (a trial wrote an R's effort as a function of e)."""
    var = _LAW_VARS[(kind, law)]
    try:
        return parse_expression(text, ChainMap({var: LAW_VARIABLES[var]}, params))
    except ExpressionError as exc:
        other = next((v for v in _VAR_WORDS if v != var and str(exc).startswith(f"undefined symbol '{v}'")), None)
        if other is None:
            raise ctx.error(where, str(exc)) from None
        keys = [k for (kd, k), v in _LAW_VARS.items() if kd == kind and v == other]
        instead = f"; a law in {other} is written under '{keys[0]}'" if keys else ""
        raise ctx.error(where, f"'{other}' in '{text}': {'an' if kind in 'RI' else 'a'} {kind} element's {law} law "
                               f"is written in {var} "
                               f"({_VAR_WORDS[var]}), not {other}{instead}") from None


def _unit(ctx: _Ctx, text: Any, where: tuple) -> str:
    try:
        return check_unit(text)
    except UnitError as exc:
        raise ctx.error(where, str(exc)) from None


def _text(spec: dict, key: str) -> str:
    value = spec.get(key, "")
    return "" if value is None else str(value)


# ---------------------------------------------------------------- model

def _build_model(data: dict, ctx: _Ctx) -> Model:
    for key in data:
        if key not in _TOP_KEYS:
            raise ctx.error((key,), f"unknown top-level key '{key}' (allowed: {', '.join(sorted(_TOP_KEYS))})")
    symbols: dict[str, sp.Expr] = {}
    taken: dict[str, str] = {}
    normal: dict[str, str] = {}          # NFKC form -> the name as written
    drawn: dict[str, str] = {}           # as a person reads it (bondgraph.names.skeleton) -> the name as written

    def claim(name: str, what: str, where: tuple) -> None:
        if name in taken:
            raise ctx.error(where, f"'{name}' is already used as {taken[name]}; names must be unique")
        other = normal.get(unicodedata.normalize("NFKC", name))
        if other is not None:
            raise ctx.error(where, f"'{name}' and '{other}' ({taken[other]}) are one name once Unicode-normalised "
                                   "(NFKC, as expressions read names: 'µ' is 'μ', 'ﬁ' is 'fi'); rename one")
        other = drawn.get(skeleton(name))
        if other is not None:
            # a trial's orifice law read a Greek capital kappa's 'Κpa' (another parameter) for 'Kpa'
            raise ctx.error(where, f"'{name}' and '{other}' ({taken[other]}) look alike ({look_alike(name, other)}); "
                                   "rename one")
        taken[name] = what
        normal[unicodedata.normalize("NFKC", name)] = name
        drawn[skeleton(name)] = name

    parameters = _parameters(ctx, data, symbols, claim)
    modes = _modes(ctx, data, symbols, claim)
    data_spec = _spec(ctx, data.get("data") or {}, ("data",), {"columns", "sampling_time"})
    raw_columns = data_spec.get("columns") or []
    if not isinstance(raw_columns, list):
        raise ctx.error(("data", "columns"), f"columns must be a list of column names such as [t, u, y], got {_shown(raw_columns)}")
    columns = tuple(_ref(ctx, c, ("data", "columns", i), "a column") for i, c in enumerate(raw_columns))
    _check_columns(ctx, columns)
    column_symbols = {c: sp.Symbol(c, real=True) for c in columns if c != "t"}
    sampling_time = (_number(ctx, data_spec["sampling_time"], ("data", "sampling_time"), "sampling_time", above=0)
                     if "sampling_time" in data_spec else None)
    for m in modes.values():
        if m.column is not None and columns and m.column not in columns:
            raise ctx.error(("modes", m.name, "column"), f"column '{m.column}' is not among data.columns {list(columns)}")
    inputs = _inputs(ctx, data, symbols, claim, columns)
    sensors = _sensors(ctx, data, symbols, claim, column_symbols, columns)
    definitions = _definitions(ctx, data, symbols, claim)
    modes = _autonomous(ctx, data, modes, symbols, sensors, inputs)
    elements = _elements(ctx, data, symbols, claim, inputs, sensors, parameters)
    junctions, mode_exprs = _junctions(ctx, data, claim, modes, symbols)
    bonds = _bonds(ctx, data, elements, junctions)
    _check_ports(ctx, elements, junctions, bonds)
    _check_sensor_junctions(ctx, sensors, junctions)
    for beta, owner in [(f"beta_{e.input or e.name}", e.input or e.name) for e in elements.values()
                        if e.kind in SOURCE_KINDS] + [(f"beta_{s}", s) for s in sensors]:
        if beta in taken:
            raise ctx.error(_where_of(taken, beta), f"'{beta}' is the efficiency factor of '{owner}'; "
                                                          "give this name to nothing else")
    for e in elements.values():
        if e.kind in SOURCE_KINDS:
            symbols[f"beta_{e.input or e.name}"] = sp.Symbol(f"beta_{e.input or e.name}", positive=True)
    for s in sensors.values():
        symbols[f"beta_{s.name}"] = sp.Symbol(f"beta_{s.name}", positive=True)
    faults = _faults(ctx, data, parameters, sensors, elements, modes)
    initial = {str(k): _number(ctx, v, ("initial", k), "initial value")
               for k, v in _mapping(ctx, data.get("initial"), ("initial",)).items()}
    _check_initial(ctx, initial, elements, sensors)
    name = data.get("name") or Path(ctx.path).stem
    if not str(name).isprintable():           # (printed in every report: a terminal would obey its escapes)
        raise ctx.error(("name",), "the model's name holds control characters (escapes, line breaks); "
                                   "write it as plain text on one line")
    if len(str(name)) > MAX_NAME:             # (every report's first line: a title, not a text)
        raise ctx.error(("name",), f"the model's name is {len(str(name)):,} characters long; keep it within "
                                   f"{MAX_NAME} (put the rest under description:)")
    plain = {k: v for k, v in symbols.items() if isinstance(v, sp.Symbol)}
    plain.update(mode_exprs)      # a junction's mode written as an expression (1 - s), under its text
    return Model(name=str(name), path=ctx.path, description=_text(data, "description"),
                 reference=_text(data, "reference"), parameters=parameters, definitions=definitions,
                 inputs=inputs, modes=modes, elements=elements, junctions=junctions, sensors=sensors,
                 bonds=bonds, faults=faults, columns=columns, sampling_time=sampling_time,
                 initial=initial, symbols=plain)


def _check_initial(ctx: _Ctx, initial: Mapping[str, float], elements: Mapping, sensors: Mapping) -> None:
    """initial: each name a storage element's (its state), a sensor's (its reading, met by solving
    for the states) or ``flow_`` and a storage element's (the simulator's outputs); a misspelt
    name is refused here, not when the first simulation or linearisation asks for it."""
    storage = [e for e, el in elements.items() if el.kind in ("C", "I")]
    known = set(storage) | set(sensors) | {f"flow_{e}" for e in storage}
    for k in initial:
        if k not in known:
            offer = ", ".join(sorted(set(storage) | set(sensors))) or "none"
            raise ctx.error(("initial", k), f"'{k}' is no storage element or sensor: give initial values by a "
                                            f"storage element's name (its state; flow_NAME its flow) or a sensor's "
                                            f"(its reading): {offer}")


def _check_columns(ctx: _Ctx, columns: tuple[str, ...]) -> None:
    """data.columns: time ``t`` among them (every record has it, in s), each name once, also once
    Unicode-normalised (NFKC)."""
    if columns and "t" not in columns:
        raise ctx.error(("data", "columns"), f"no time column t (in s), which every record has; got "
                                             f"{list(columns)[:4]}{' ...' if len(columns) > 4 else ''}: write "
                                             f"[t, {', '.join(columns[:3])}, ...]")
    pair = same_name(columns)
    if pair:
        i, j = pair
        first, c = columns[i], columns[j]
        what = (f"'{c}' is listed twice" if first == c else
                f"'{first}' and '{c}' are one name once Unicode-normalised (NFKC)")
        raise ctx.error(("data", "columns", j), f"{what} (items {i} and {j}); give each column once")


def _where_of(taken: dict, name: str) -> tuple:
    section = {"a parameter": "parameters", "a mode variable": "modes", "an input": "inputs",
               "a sensor signal": "sensors", "a definition": "definitions", "an element": "elements",
               "a junction": "junctions"}.get(taken[name], "parameters")
    return (section, name)


def _parameters(ctx, data, symbols, claim) -> dict[str, Parameter]:
    out: dict[str, Parameter] = {}
    for name, spec in _mapping(ctx, data.get("parameters"), ("parameters",)).items():
        where = ("parameters", name)
        _name(ctx, name, where)
        if not isinstance(spec, dict):
            spec = {"value": spec}
        _spec(ctx, spec, where, {"value", "unit", "description"})
        if "value" not in spec or spec["value"] is None:
            raise ctx.error(where, f"parameter '{name}' has no value; add value: <number> (SI units)")
        value = _number(ctx, spec["value"], where + ("value",), f"parameter '{name}'", infinite=True)
        if math.isfinite(value) and abs(value) > MAX_CONSTANT:   # as a number in an expression: its products overflow
            raise ctx.error(where + ("value",), f"parameter '{name}' is {value:g}, beyond 1e300 in magnitude; "
                                               "give its value in SI units, or .inf for an infinite one")
        if value != 0 and abs(value) < 1.0 / MAX_CONSTANT:   # its reciprocal (q/C, e/R) overflows
            raise ctx.error(where + ("value",), f"parameter '{name}' is {value:g}, below 1e-300 in magnitude: "
                                               "a law dividing by it overflows; give its value in SI units")
        unit = _unit(ctx, spec.get("unit"), where + ("unit",))
        claim(name, "a parameter", where)
        # physical constants with a positive nominal value are positive: sign(k*x) -> sign(x)
        symbols[name] = sp.Symbol(name, positive=True) if value > 0 else sp.Symbol(name, real=True)
        out[name] = Parameter(name, value, unit, _text(spec, "description"))
    return out


def _modes(ctx, data, symbols, claim) -> dict[str, Mode]:
    out: dict[str, Mode] = {}
    for name, spec in _mapping(ctx, data.get("modes"), ("modes",)).items():
        where = ("modes", name)
        _name(ctx, name, where)
        spec = _spec(ctx, spec if spec is not None else {}, where, {"nominal", "description", "column", "expr",
                                                                    "positive"})
        nominal = spec.get("nominal", 1)
        if nominal not in (0, 1) or isinstance(nominal, bool):
            raise ctx.error(where + ("nominal",), f"mode '{name}' nominal value must be 0 or 1")
        column = None if spec.get("column") is None else _ref(ctx, spec["column"], where + ("column",), "column")
        expr = None
        if spec.get("expr") is not None:
            if column is None:
                raise ctx.error(where + ("expr",), "expr is the command a simulation gives a commanded mode; "
                                                   "give column: <data column of the command> too")
            params = {k: v for k, v in symbols.items()}
            params["t"] = t
            expr = _expr(ctx, spec["expr"], where + ("expr",), params)
        if spec.get("positive") is not None and (column is not None or expr is not None):
            raise ctx.error(where + ("positive",), "a mode is commanded (column, expr) or autonomous (positive), "
                                                   "not both")
        claim(name, "a mode variable", where)
        symbols[name] = sp.Symbol(name, real=True)
        out[name] = Mode(name, int(nominal), _text(spec, "description"), column, expr)
    return out


def _autonomous(ctx, data, modes, symbols, sensors, inputs) -> dict[str, Mode]:
    """Autonomous modes' conditions (``positive:``, an expression of sensor signals and inputs),
    parsed once the sensors and inputs are known."""
    out = dict(modes)
    allowed = {k: symbols[k] for k in list(sensors) + list(inputs)}
    allowed.update({k: v for k, v in symbols.items() if k not in modes and isinstance(v, sp.Symbol)
                    and k not in allowed})
    for name, spec in _mapping(ctx, data.get("modes"), ("modes",)).items():
        if not isinstance(spec, dict) or spec.get("positive") is None:
            continue
        where = ("modes", name, "positive")
        text = spec["positive"]
        if isinstance(text, str) and any(c in text for c in "<>="):
            raise ctx.error(where, f"'{text}': give the expression that is above zero while the mode is 1, without "
                                   "a comparison (positive: iL for a diode conducting while iL > 0; iL - 0.05 to offset it)")
        if isinstance(text, str) and re.search(r"(?<![A-Za-z0-9_.])t(?![A-Za-z0-9_])", text) and "t" not in allowed:
            raise ctx.error(where, f"'{text}' reads the time t: an autonomous mode follows the sign of a signal; a "
                                   "mode that switches at given times is a commanded one (column: its logged value, "
                                   "expr: \"heaviside(t - 30)\" for bgfdi simulate)")
        try:                 # parsed with the modes known: which of them it reads
            seen = _expr(ctx, text, where, {**allowed, **{m: symbols[m] for m in modes if m in symbols}}).free_symbols
        except ModelError:
            seen = set()     # (the parse below says what is wrong)
        read = sorted(m for m in modes if m in symbols and symbols[m] in seen)
        if read:
            raise ctx.error(where, f"'{text}' reads the mode variable(s) {', '.join(read)}: an autonomous mode's "
                                   "condition reads sensor signals and inputs only; a junction that switches with "
                                   "two modes takes their product as its mode (mode: \"th*fan\")")
        expr = _expr(ctx, text, where, allowed)
        if not expr.free_symbols & {symbols[k] for k in list(sensors) + list(inputs)}:
            raise ctx.error(where, f"'{spec['positive']}' uses no sensor or input; an autonomous mode follows the "
                                   "sign of a signal (a diode's current: positive: iL)")
        out[name] = Mode(name, modes[name].nominal, modes[name].description, positive=expr)
    return out


def _inputs(ctx, data, symbols, claim, columns) -> dict[str, Input]:
    out: dict[str, Input] = {}
    for name, spec in _mapping(ctx, data.get("inputs"), ("inputs",)).items():
        where = ("inputs", name)
        _name(ctx, name, where)
        spec = _spec(ctx, spec if spec is not None else {}, where, {"column", "expr", "unit", "description"})
        column = spec.get("column")
        if column is not None:
            column = _ref(ctx, column, where + ("column",), "column")
        if column is not None and columns and column not in columns:
            raise ctx.error(where + ("column",), f"column '{column}' is not among data.columns {list(columns)}")
        expr = None
        if spec.get("expr") is not None:
            allowed = {k: v for k, v in symbols.items()}
            allowed["t"] = t
            expr = _expr(ctx, spec["expr"], where + ("expr",), allowed)
        if column is None and expr is None:
            raise ctx.error(where, f"input '{name}' needs column: <data column> or expr: <expression of t>")
        claim(name, "an input", where)
        symbols[name] = sp.Symbol(name, real=True)
        out[name] = Input(name, _unit(ctx, spec.get("unit"), where + ("unit",)),
                          None if column is None else str(column), expr, _text(spec, "description"))
    return out


def _sensors(ctx, data, symbols, claim, column_symbols, columns) -> dict[str, Sensor]:
    """The sensors; two that read one signal (the same column, or the same expression of
    columns) are refused: the second is the first measurement again, not a second sensor, and
    the residual between them is zero by construction, which the signature matrix would count
    as detecting faults it never sees."""
    out: dict[str, Sensor] = {}
    read: dict[sp.Expr, str] = {}
    for name, spec in _mapping(ctx, data.get("sensors"), ("sensors",)).items():
        where = ("sensors", name)
        _name(ctx, name, where)
        spec = _spec(ctx, spec, where, {"type", "junction", "measures", "column", "expr", "unit",
                                        "noise", "resolution", "columns", "description"})
        kind = spec.get("type")
        if kind not in SENSOR_KINDS:
            raise ctx.error(where + ("type",), f"sensor type '{kind}' unknown; use De (effort) or Df (flow)")
        if not spec.get("junction"):
            raise ctx.error(where, f"sensor '{name}' is on no junction; add junction: <name of a 0- or 1-junction>")
        _ref(ctx, spec["junction"], where + ("junction",), "junction")
        default = "effort" if kind == "De" else "flow"
        measures = spec.get("measures", default)
        allowed = ("effort", "momentum") if kind == "De" else ("flow", "displacement")
        if measures not in allowed:
            raise ctx.error(where + ("measures",), f"a {kind} sensor measures {' or '.join(allowed)}, not '{measures}'")
        if spec.get("expr") is not None:
            if not columns:
                raise ctx.error(where + ("expr",), "list the data columns under data.columns to use them in expr")
            signal = _expr(ctx, spec["expr"], where + ("expr",), column_symbols)
        else:
            column = _ref(ctx, spec.get("column", name), where + ("column",), "column")
            if columns and column not in columns:
                raise ctx.error(where + ("column",), f"column '{column}' is not among data.columns {list(columns)}")
            if str(column) == "t":
                raise ctx.error(where + ("column",), f"sensor '{name}' reads column 't', the time (s) of every "
                                                     "measurement file; give it the column of its measurement")
            signal = sp.Symbol(str(column), real=True)
        outputs = {}
        for col, text in _mapping(ctx, spec.get("columns"), where + ("columns",)).items():
            if str(col) not in {str(x) for x in signal.free_symbols}:
                raise ctx.error(where + ("columns", col), f"'{col}' is not a column this sensor reads")
            outputs[str(col)] = _expr(ctx, text, where + ("columns", col),
                                      {**{k: v for k, v in symbols.items() if isinstance(v, sp.Symbol)},
                                       name: sp.Symbol(name, real=True)})
        if signal in read:
            key = "expr" if spec.get("expr") is not None else "column"
            raise ctx.error(where + (key,), f"sensor '{name}' reads {_signal_text(signal)} as sensor '{read[signal]}' "
                                            "does: one measurement, not two (their residual is zero by "
                                            "construction); give it its own data column or remove it")
        read[signal] = name
        noise = _per_column(ctx, spec.get("noise"), where + ("noise",), signal)
        resolution = _per_column(ctx, spec.get("resolution"), where + ("resolution",), signal)
        claim(name, "a sensor signal", where)
        symbols[name] = sp.Symbol(name, real=True)
        out[name] = Sensor(name, kind, str(spec["junction"]), measures, signal,
                           _unit(ctx, spec.get("unit"), where + ("unit",)), noise, resolution,
                           _text(spec, "description"), outputs)
    for name, sensor in out.items():
        # a signal computed only from columns other sensors read is theirs again (a user trial's
        # 'theta_m/10 - theta_L' beside both encoders: a residual zero by construction, calibrated to
        # 7e-11 and said to detect both encoders' faults)
        if isinstance(sensor.signal, sp.Symbol):
            continue
        columns = {str(x) for x in sensor.signal.free_symbols}
        readers = {c: [o for o, other in out.items() if o != name and c in {str(x) for x in other.signal.free_symbols}]
                   for c in columns}
        if columns and all(readers.values()):
            raise ctx.error(("sensors", name, "expr"),
                            f"sensor '{name}' computes '{sensor.signal}' from columns other sensors read ("
                            + ", ".join(f"{c} by {readers[c][0]}" for c in sorted(columns))
                            + "): no measurement of its own, and a residual comparing it with them is zero by "
                              "construction; remove it (a storage element's state these sensors measure is read "
                              "from them: docs/model-format.md, Sensors; a law relating these signals belongs in "
                              "the model, as an element's)")
    return out


def _signal_text(signal: sp.Expr) -> str:
    return f"column '{signal}'" if isinstance(signal, sp.Symbol) else f"'{signal}'"


def _per_column(ctx, value, where, signal: sp.Expr) -> dict[str, float]:
    """A measurement setting given once for all the sensor's columns, or per column."""
    if value is None:
        return {}
    cols = sorted(str(s) for s in signal.free_symbols)
    if isinstance(value, dict):
        for k in value:
            if k not in cols:
                raise ctx.error(where + (k,), f"'{k}' is not a column of this sensor ({', '.join(cols)})")
        return {str(k): _number(ctx, v, where + (k,), "value", minimum=0) for k, v in value.items()}
    number = _number(ctx, value, where, "value", minimum=0)
    return {c: number for c in cols}


def _definitions(ctx, data, symbols, claim) -> dict[str, sp.Expr]:
    out: dict[str, sp.Expr] = {}
    for name, text in _mapping(ctx, data.get("definitions"), ("definitions",)).items():
        where = ("definitions", name)
        _name(ctx, name, where)
        expr = _expr(ctx, text, where, symbols)
        claim(name, "a definition", where)
        symbols[name] = expr
        out[name] = expr
    return out


_ELEMENT_KEYS = {
    "Se": {"value"}, "Sf": {"value"}, "MSe": {"input", "value"}, "MSf": {"input", "value"},
    "R": {"parameter", "effort", "flow"}, "C": {"parameter", "effort", "displacement"},
    "I": {"parameter", "flow", "momentum"},
    "TF": {"modulus"}, "GY": {"modulus"}, "MTF": {"modulus"}, "MGY": {"modulus"},
}
# Which local variable each nonlinear law may use.
_LAW_VARS = {("R", "effort"): "f", ("R", "flow"): "e", ("C", "effort"): "q",
             ("C", "displacement"): "e", ("I", "flow"): "p", ("I", "momentum"): "f"}


def _elements(ctx, data, symbols, claim, inputs, sensors, parameters) -> dict[str, Element]:
    out: dict[str, Element] = {}
    params = dict(symbols)           # once, not per element: a copy each would make loading quadratic
    for name, spec in _mapping(ctx, data.get("elements"), ("elements",), required=True).items():
        where = ("elements", name)
        _name(ctx, name, where)
        if not isinstance(spec, dict):
            raise ctx.error(where, "must be a mapping such as {type: R, parameter: R1}")
        kind = spec.get("type")
        if kind is None:
            raise ctx.error(where, f"has no type: give one, such as {{type: R, parameter: R1}} "
                                   f"(types: {', '.join(ELEMENT_KINDS)})")
        if kind not in ELEMENT_KINDS:
            raise ctx.error(where + ("type",),
                            f"unknown element type '{kind}' (use one of {', '.join(ELEMENT_KINDS)}; "
                            "sensors go under sensors:, junctions under junctions:)")
        _spec(ctx, spec, where, _ELEMENT_KEYS[kind] | {"type", "description"})
        claim(name, "an element", where)
        element = Element(name=name, kind=kind, description=_text(spec, "description"))
        fields: dict[str, Any] = {}
        if kind in ("R", "C", "I"):
            if spec.get("parameter") is not None:
                pname = _ref(ctx, spec["parameter"], where + ("parameter",), "parameter")
                if pname not in symbols or not isinstance(symbols[pname], sp.Symbol):
                    raise ctx.error(where + ("parameter",), f"undefined parameter '{pname}'{_meant(pname, parameters)}; "
                                                            "add it under parameters")
                value = getattr(parameters.get(symbols[pname].name), "value", None)    # (a definition's alias too)
                if kind in ("C", "I") and value is not None and not value > 0:
                    what = {"C": "a capacitance (compliance)", "I": "an inertance (mass, inductance)"}[kind]
                    raise ctx.error(where + ("parameter",), f"{kind} element '{name}' reads parameter '{pname}' = "
                                    f"{value:g}; {what} stores energy only when positive: give its positive "
                                    "value (SI units)")
                fields["parameter"] = pname
            laws = {}
            for law in _ELEMENT_KEYS[kind] - {"parameter"}:
                if spec.get(law) is not None:
                    laws[law] = _law(ctx, spec[law], where + (law,), kind, law, params)
                    _in_domain(ctx, where + (law,), laws[law], parameters, spec[law])
            if kind in ("C", "I"):
                laws = _storage_laws(ctx, where, kind, laws, fields.get("parameter"))
            elif len(laws) == 2:
                _check_inverse(ctx, where, laws["effort"], "f", laws["flow"], "e", "effort", "flow")
            if not laws and "parameter" not in fields:
                hint = {"R": "parameter: R1, or effort: <law in f> / flow: <law in e>",
                        "C": "parameter: C1, or effort: <law in q>", "I": "parameter: I1, or flow: <law in p>"}[kind]
                raise ctx.error(where, f"{kind} element '{name}' has no constitutive law; add {hint}")
            fields["laws"] = laws
        elif kind in TWO_PORT_KINDS:
            if spec.get("modulus") is None:
                raise ctx.error(where, f"{kind} element '{name}' needs modulus: <expression>")
            modulus = _expr(ctx, spec["modulus"], where + ("modulus",), params)
            _in_domain(ctx, where + ("modulus",), modulus, parameters, spec["modulus"])
            if kind in ("TF", "GY"):
                signals = [s for s in modulus.free_symbols if s.name in inputs or s.name in sensors]
                if signals:
                    raise ctx.error(where + ("modulus",),
                                    f"a {kind} modulus must be constant but uses {sorted(s.name for s in signals)}; "
                                    f"use M{kind} for a modulated one")
                _nonzero_modulus(ctx, where, kind, name, modulus, parameters)
            fields["modulus"] = modulus
        else:
            if kind in ("MSe", "MSf") and spec.get("input") is not None and spec.get("value") is not None:
                # one of them was dropped, silently: a trial's "-Iinv" lost its sign to input: Iinv
                raise ctx.error(where, f"source '{name}' has both input and value; keep one: input: <name> for "
                                       "the signal itself, value: <expression> for an expression of it")
            if kind in ("MSe", "MSf") and spec.get("input") is not None:
                _ref(ctx, spec["input"], where + ("input",), "input")
                if spec["input"] not in inputs:
                    raise ctx.error(where + ("input",), f"undefined input '{spec['input']}'; add it under inputs")
                fields["input"] = spec["input"]
            elif spec.get("value") is not None:
                fields["value"] = _expr(ctx, spec["value"], where + ("value",), ChainMap({"t": t}, params))
                _in_domain(ctx, where + ("value",), fields["value"], parameters, spec["value"])
            else:
                need = "input: <input name>" if kind.startswith("M") else "value: <number or expression of t>"
                raise ctx.error(where, f"source '{name}' needs {need}")
        out[name] = replace(element, **fields)
    return out


def _in_domain(ctx, where: tuple, expr: sp.Expr, parameters, text) -> None:
    """A part of a law, modulus or source value that reads parameters only, and leaves its
    function's domain at their values (a logarithm or root of a negative value, asin(2 k)), is
    refused where it is written: every residual that reads it would be NaN on every sample."""
    values = {s: v for s in expr.free_symbols
              if (v := getattr(parameters.get(s.name), "value", None)) is not None}
    part = left_domain(expr, values) if values else None
    if part is None:
        return
    at = ", ".join(f"{s} = {values[s]:g}" for s in sorted(part.free_symbols & values.keys(), key=str))
    raise ctx.error(where, f"'{part}' in '{text}' is not a finite real number at the parameters' values ({at}): "
                           "every residual that reads it would be NaN on every sample; check the sign of the "
                           "parameter or of the expression")


def _nonzero_modulus(ctx, where, kind: str, name: str, modulus: sp.Expr, parameters) -> None:
    """A TF or GY whose modulus is 0 (or not finite) at the parameters' values couples nothing: its
    two sides are two systems, and the derivation divides by it (a loudspeaker's cone area typed as
    0 gave a residual of inf). Refused with the value; a modulus that reads no value is left."""
    values = {s: getattr(parameters.get(s.name), "value", None) for s in modulus.free_symbols}
    if any(v is None for v in values.values()):
        return
    try:
        number = complex(modulus.xreplace({s: sp.Float(v) for s, v in values.items()}))
    except (TypeError, ValueError, OverflowError):
        return
    if number == 0 or not (math.isfinite(number.real) and math.isfinite(number.imag)):
        at = ", ".join(f"{s} = {v:g}" for s, v in sorted(values.items(), key=lambda x: str(x[0])))
        said = "0" if number == 0 else "not finite"
        raise ctx.error(where + ("modulus",), f"{kind} element '{name}' has modulus {modulus}, {said} at the "
                        f"parameters' values{f' ({at})' if at else ''}: a {kind} of modulus 0 or not finite couples "
                        "nothing (its two sides are two systems) and the derivation divides by it; give its "
                        "nonzero, finite value (SI units), or remove the element")


def _check_inverse(ctx, where, law: sp.Expr, law_var: str, inverse: sp.Expr, inverse_var: str,
                   law_key: str, inverse_key: str) -> None:
    """A declared law pair must be one relation: inverse(law(x)) = x at sample points (parameters at
    sample values too, so a pair that only agrees at the nominal values is still caught), or, where
    the law is not one-to-one, another x with the same law(x): the inverse is then one branch of it
    (a pendulum's gravity torque mgl sin(q) and its displacement asin(e / mgl) on |q| < pi/2)."""
    x = LAW_VARIABLES[law_var]
    params = sorted((law.free_symbols | inverse.free_symbols) - set(LAW_VARIABLES.values()), key=str)
    rng = [0.37, 1.9, 0.83, 2.6, 1.3]
    values = {p: sp.Float(0.5 + 0.37 * i) for i, p in enumerate(params)}
    for v in rng:
        try:
            out = law.xreplace({**values, x: sp.Float(v)})
            back = sp.N(inverse.xreplace({**values, LAW_VARIABLES[inverse_var]: out}))
        except (TypeError, ValueError, ZeroDivisionError):          # pragma: no cover - sympy edge cases
            continue
        if not back.is_number or not back.is_finite:
            continue
        if abs(complex(back) - v) > 1e-6 * max(1.0, abs(v)) and not _same_image(law, values, x, back, out):
            raise ctx.error(where + (inverse_key,),
                            f"'{inverse_key}' is not the inverse of '{law_key}' ({law_key} at {law_var} = {v} gives "
                            f"{sp.N(out, 6)}, and {inverse_key} of that gives {law_var} = {sp.N(back, 6)}, not {v}); "
                            "give one relation in both forms, or only one of them")


def _same_image(law: sp.Expr, values: dict, x: sp.Symbol, back: sp.Expr, out: sp.Expr) -> bool:
    """law(back) = out: ``back`` is another point the law maps where ``out`` came from."""
    try:
        again = complex(sp.N(law.xreplace({**values, x: back})))
        out = complex(sp.N(out))
    except (TypeError, ValueError, ZeroDivisionError):          # pragma: no cover - sympy edge cases
        return False
    return abs(again - out) <= 1e-6 * max(1.0, abs(out))


def _storage_laws(ctx, where, kind: str, laws: dict, parameter: str | None) -> dict:
    """A C (I) given by its effort (flow) law only gets the inverse law, solved symbolically where
    sympy finds one solution, for derivative causality; a law it cannot invert (k q + k3 q^3: three
    roots) is kept as given, and causality asks for the inverse only where it is needed
    (:func:`bondgraph.laws.has_inverse`: a state no sensor reads, in derivative causality). A pair
    given both ways is checked for consistency."""
    law_key, inv_key, energy, local = STORAGE_KEYS[kind]
    if parameter is not None and laws:
        raise ctx.error(where, f"give either parameter: or laws ({law_key}/{inv_key}), not both")
    if law_key in laws and inv_key in laws:
        _check_inverse(ctx, where, laws[law_key], energy, laws[inv_key], local, law_key, inv_key)
    elif law_key in laws:
        x, y = LAW_VARIABLES[energy], LAW_VARIABLES[local]
        law = laws[law_key]
        solved = None
        if law.has(x) and not law.has(sp.sign, sp.Abs, sp.Heaviside, sp.Min, sp.Max):
            try:
                solved = sp.solve(sp.Eq(y, law), x, dict=False)
            except (NotImplementedError, TypeError, ValueError):   # pragma: no cover - sympy edge cases
                solved = None
        if solved and len(solved) == 1:
            laws = {**laws, inv_key: solved[0]}
    elif inv_key in laws:
        raise ctx.error(where, f"{kind} element has {inv_key}: but no {law_key}: <law in {energy}>; add it "
                               "(the simulator integrates the energy variable)")
    return laws


def _junctions(ctx, data, claim, modes, symbols) -> tuple[dict[str, Junction], dict[str, sp.Expr]]:
    out: dict[str, Junction] = {}
    exprs: dict[str, sp.Expr] = {}
    for name, spec in _mapping(ctx, data.get("junctions"), ("junctions",), required=True).items():
        where = ("junctions", name)
        _name(ctx, name, where)
        if not isinstance(spec, dict):
            spec = {"type": spec}
        _spec(ctx, spec, where, {"type", "mode", "switched_off", "description"})
        kind = str(spec.get("type"))
        if kind not in JUNCTION_KINDS:
            raise ctx.error(where + ("type",), f"unknown junction type '{kind}' (use 0, 1, 0c or 1c)")
        mode = spec.get("mode")
        off = spec.get("switched_off", "all")
        if kind.endswith("c"):
            if mode is None:
                raise ctx.error(where, f"controlled junction '{name}' needs mode: <mode variable>")
            if isinstance(mode, str) and mode.strip() in modes:
                mode = mode.strip()
            else:
                mode = _mode_expression(ctx, mode, where + ("mode",), modes, symbols, exprs)
            if off not in OFF_SEMANTICS:
                raise ctx.error(where + ("switched_off",), f"switched_off must be {' or '.join(OFF_SEMANTICS)}, not {_shown(off)} "
                                                  "(docs/model-format.md, Controlled junctions)")
        else:
            if mode is not None:
                raise ctx.error(where + ("mode",), f"junction '{name}' is type {kind}; use {kind}c for a controlled junction")
            if "switched_off" in spec:
                raise ctx.error(where + ("switched_off",), f"junction '{name}' is type {kind}; switched_off: is for "
                                                           "controlled junctions")
        claim(name, "a junction", where)
        out[name] = Junction(name, kind, mode, _text(spec, "description"), off=str(off) if kind.endswith("c") else "all")
    return out, exprs


def _mode_expression(ctx, text, where, modes, symbols, exprs) -> str:
    """A junction's mode as an expression of mode variables (a diode that conducts while the
    switch is open: ``1 - s``); it must be 0 or 1 in every combination of its variables. Returned
    as its text, under which the expression is filed among the model's symbols."""
    if not isinstance(text, str) or not text.strip():
        raise ctx.error(where, f"mode must name a mode variable or be an expression of them such as 1 - s, "
                               f"not {_shown(text)}")
    known = {m: symbols[m] for m in modes}
    expr = _expr(ctx, text, where, known)
    used = sorted(expr.free_symbols, key=lambda x: x.name)
    if not used:
        raise ctx.error(where, f"mode '{text}' uses no mode variable; define one under modes")
    for values in product((0, 1), repeat=len(used)):
        v = expr.xreplace(dict(zip(used, map(sp.Integer, values))))
        if v not in (0, 1):
            point = ", ".join(f"{s.name}={x}" for s, x in zip(used, values))
            raise ctx.error(where, f"mode '{text}' is {v} at {point}; a mode must be 0 or 1 in every combination "
                                   "(use products and 1 - x: s*(1 - d))")
    key = str(expr)
    exprs[key] = expr
    return key


def _bonds(ctx, data, elements, junctions) -> tuple[Bond, ...]:
    raw = data.get("bonds")
    if not isinstance(raw, dict) or not raw:
        raise ctx.error(("bonds",), "bonds must be a mapping of id: [from, to] (power goes from -> to)")
    bonds: list[Bond] = []
    seen: dict[frozenset, int] = {}
    for bid, ends in raw.items():
        where = ("bonds", bid)
        if isinstance(bid, bool) or not isinstance(bid, int) or bid < 0:
            raise ctx.error(where, f"bond id '{bid}' must be a non-negative integer")
        if not isinstance(ends, list) or len(ends) != 2:
            raise ctx.error(where, f"bond {bid} must be [from, to], got {ends!r}")
        src, dst = (str(x) for x in ends)
        for end in (src, dst):
            if end not in elements and end not in junctions:
                raise ctx.error(where, f"bond {bid} is dangling: '{end}' is neither an element nor a junction")
        if src == dst:
            raise ctx.error(where, f"bond {bid} connects '{src}' to itself")
        pair = frozenset((src, dst))
        if pair in seen:
            raise ctx.error(where, f"duplicate bond: {bid} joins {src} and {dst} like bond {seen[pair]}; remove one")
        seen[pair] = bid
        bonds.append(Bond(bid, src, dst))
    return tuple(bonds)


def _check_ports(ctx, elements, junctions, bonds) -> None:
    at: dict[str, list] = {}           # the bonds at each node, in file order (one pass, not one per node)
    for b in bonds:
        at.setdefault(b.source, []).append(b)
        at.setdefault(b.target, []).append(b)
    for name, e in elements.items():
        attached = at.get(name, [])
        where = ("elements", name)
        if e.kind in TWO_PORT_KINDS:
            if len(attached) != 2:
                raise ctx.error(where, f"{e.kind} '{name}' has {len(attached)} bond(s); it needs exactly two "
                                       "(one bringing power in, one taking it out)")
            ins = [b for b in attached if b.target == name]
            if len(ins) != 1:
                raise ctx.error(where, f"{e.kind} '{name}': power must pass through it: one bond in, one out "
                                       f"(bonds {', '.join(str(b.id) for b in attached)})")
        elif len(attached) != 1:
            raise ctx.error(where, f"{e.kind} '{name}' has {len(attached)} bonds; a one-port element needs exactly one")
        elif e.kind in ("C", "I", "R") and attached[0].source == name:
            # the laws take the bond's flow as the element's own (q' = f, p' = e, power e*f taken in):
            # a bond drawn outwards charged a trial's battery cell while it discharged, silently
            b = attached[0]
            raise ctx.error(("bonds", b.id), f"bond {b.id} points away from {e.kind} '{name}'; power goes into a "
                                             f"C, I or R element: write it [{b.target}, {name}]")
    for name, j in junctions.items():
        attached = at.get(name, [])
        if not attached:
            raise ctx.error(("junctions", name), f"junction '{name}' has no bonds; connect it or remove it")
        if j.kind.endswith("c") and len(attached) < 2:
            raise ctx.error(("junctions", name), f"controlled junction '{name}' has {len(attached)} bond; it switches "
                                                 "power between at least two")


def _check_sensor_junctions(ctx, sensors, junctions) -> None:
    for s in sensors.values():
        where = ("sensors", s.name, "junction")
        if s.junction not in junctions:
            raise ctx.error(where, f"sensor '{s.name}' is on '{s.junction}', which is no junction "
                                   f"(junctions: {', '.join(junctions)})")
        base = junctions[s.junction].base
        want = "0" if s.kind == "De" else "1"
        if base != want:
            raise ctx.error(where, f"a {s.kind} sensor measures the common {'effort' if want == '0' else 'flow'} "
                                   f"of a {want}-junction; '{s.junction}' is a {base}-junction")


def inputs_of(sources: Mapping[str, Element]) -> set[str]:
    """The source names a fault may give that are input signals (not fixed values)."""
    return {name for name, e in sources.items() if e.input}


def _faults(ctx, data, parameters, sensors, elements, modes) -> dict[str, Fault]:
    out: dict[str, Fault] = {}
    sources = {e.input or e.name: e for e in elements.values() if e.kind in SOURCE_KINDS}
    for name, spec in _mapping(ctx, data.get("faults"), ("faults",)).items():
        where = ("faults", name)
        spec = _spec(ctx, spec, where, {"kind", "parameters", "sensor", "source", "mode", "value", "effect",
                                        "description"} | MONITOR_FAULT_KEYS)
        kind = spec.get("kind")
        if kind not in FAULT_KINDS:
            raise ctx.error(where + ("kind",), f"fault kind '{kind}' unknown (use {', '.join(FAULT_KINDS)})")
        if kind == "parametric":
            targets = spec.get("parameters")
            if isinstance(targets, str):
                targets = [targets]
            if not targets or not isinstance(targets, list):
                raise ctx.error(where, "a parametric fault needs parameters: [names]")
            targets = [_ref(ctx, p, where + ("parameters",), "a parameter") for p in targets]
            for p in targets:
                if p not in parameters:
                    raise ctx.error(where + ("parameters",), f"undefined parameter '{p}' in fault '{name}'"
                                                             f"{_meant(p, parameters)}")
            twice = sorted({p for p in targets if targets.count(p) > 1})
            if twice:
                raise ctx.error(where + ("parameters",), f"{', '.join(twice)} listed twice in fault '{name}': "
                                "name each parameter once")
        else:
            key = kind
            target = spec.get(key)
            if target is not None:
                target = _ref(ctx, target, where + (key,), key)
            pool = {"sensor": sensors, "source": sources, "mode": modes}[kind]
            if target not in pool:
                raise ctx.error(where + (key,), f"fault '{name}' names {key} '{target}', which is not defined "
                                                f"(known: {', '.join(pool) or 'none'})")
            targets = [target]
        effect = spec.get("effect", "gain")
        if kind in ("sensor", "source"):
            if effect not in FAULT_EFFECTS:
                raise ctx.error(where + ("effect",), f"effect must be {', '.join(FAULT_EFFECTS)}, not {_shown(effect)}")
            if effect == "bias" and kind == "source" and targets[0] not in inputs_of(sources):
                raise ctx.error(where + ("effect",), f"an offset acts on a source's input signal; source "
                                                     f"'{targets[0]}' has a fixed value: give it an input, or use gain")
            if effect == "stuck" and kind != "sensor":
                raise ctx.error(where + ("effect",), "a stuck fault is a sensor's (a frozen reading); "
                                                     "for a source use gain or bias")
        elif "effect" in spec:
            raise ctx.error(where + ("effect",), f"effect is for sensor and source faults, not {kind}")
        value = spec.get("value")
        if kind == "mode":
            value = 0 if value is None else value
            if value not in (0, 1):
                raise ctx.error(where + ("value",), "a fault mode's value is 0 or 1")
        out[name] = Fault(name, kind, tuple(str(x) for x in targets),
                          None if value is None else _number(ctx, value, where + ("value",), "value"),
                          _text(spec, "description"), effect=str(effect) if kind in ("sensor", "source") else "gain")
    return out
