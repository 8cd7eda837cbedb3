r"""Java ``.properties`` text as JPK writes it: parsing, unescaping and shared-data references.

JPK archives store every header as a Java properties file (ISO-8859-1 text, ``key=value`` lines,
``#``/``!`` comments, backslash escapes such as ``\:``, ``\ `` and ``\u00B5``). A header may
point into ``shared-data/header.properties`` with a reference key ``<prefix>.<block>.*=<N>``:
every shared key ``<block>.<N>.<rest>`` then belongs to the header as ``<prefix>.<rest>``
(``channel.height.lcd-info.*=0`` and ``force-segment-header.force-segment-header-info.*=2``).

Also here: typed access to header values and the calibration chain of a channel
(``channel.<ch>.conversion-set.*``). Errors are :class:`HeaderError` and say *what* is wrong; the
archive reader adds *where* (file and member).
"""

from __future__ import annotations

import re

import numpy as np

from viscoforce._typing import FloatArray
from viscoforce.exceptions import ViscoforceError


class HeaderError(ViscoforceError, ValueError):
    """A header is unreadable, lacks a key or holds a bad value; the message names the key.

    Private to :mod:`viscoforce.io`: the archive reader turns it into an InstrumentFormatError
    that also names the file and the member.
    """


_ESCAPES = {"t": "\t", "n": "\n", "r": "\r", "f": "\f"}
_KEY = re.compile(r"(?:\\.|[^\\=: \t\f])*\\?", re.S)  # up to the first unescaped separator
_REFERENCE_SUFFIX = ".*"
_LINE_BREAK = re.compile(r"\r\n|\r|\n")  # Java's line terminators only (not \x85 etc.)


def _logical_lines(text: str) -> list[str]:
    """Join continuation lines (an odd number of trailing backslashes) and drop comments."""
    lines: list[str] = []
    pending = ""
    for physical in _LINE_BREAK.split(text):
        line = physical.lstrip(" \t\f")
        if not pending and (not line or line[0] in "#!"):
            continue
        if (len(line) - len(line.rstrip("\\"))) % 2:
            pending += line[:-1]
            continue
        lines.append(pending + line)
        pending = ""
    if pending:
        lines.append(pending)
    return lines


def unescape(text: str) -> str:
    r"""Resolve Java properties escapes: ``\t \n \r \f``, ``\uXXXX`` and ``\c`` -> ``c``.

    Parameters
    ----------
    text : str
        Raw key or value text.

    Returns
    -------
    str
        The text with every escape resolved in a single left-to-right pass.

    Raises
    ------
    HeaderError
        For a malformed ``\uXXXX`` escape.
    """
    if "\\" not in text:
        return text
    out: list[str] = []
    i = 0
    while i < len(text):
        char = text[i]
        if char != "\\" or i + 1 == len(text):
            out.append(char)
            i += 1
            continue
        code = text[i + 1]
        if code == "u":
            digits = text[i + 2:i + 6]
            if len(digits) != 4 or any(c not in "0123456789abcdefABCDEF" for c in digits):
                raise HeaderError(f"malformed \\uXXXX escape {text[i:i + 6]!r}")
            out.append(chr(int(digits, 16)))
            i += 6
        else:
            out.append(_ESCAPES.get(code, code))
            i += 2
    return "".join(out)


def _split(line: str) -> tuple[str, str]:
    """Split a logical line at the first unescaped separator (``=``, ``:`` or whitespace)."""
    end = _KEY.match(line).end()
    rest = line[end:].lstrip(" \t\f")
    if rest[:1] in ("=", ":"):
        rest = rest[1:].lstrip(" \t\f")
    return line[:end], rest


def parse_properties(data: bytes) -> dict[str, str]:
    r"""Parse a Java properties file.

    Parameters
    ----------
    data : bytes
        File content (ISO-8859-1, as Java writes it; non-Latin characters arrive as ``\uXXXX``).

    Returns
    -------
    dict of str to str
        Unescaped keys and values in file order; a repeated key keeps its last value.

    Raises
    ------
    HeaderError
        For a malformed ``\uXXXX`` escape.
    """
    text = data.decode("latin-1")
    props: dict[str, str] = {}
    for line in _logical_lines(text):
        i = line.find("=")
        key = line[:i]
        if i > 0 and "\\" not in line and not any(c in key for c in ": \t\f"):  # the usual line
            props[key] = line[i + 1:].lstrip(" \t\f")
            continue
        key, value = _split(line)
        props[unescape(key)] = unescape(value)
    return props


def group_blocks(shared: dict[str, str]) -> dict[str, dict[str, str]]:
    """Group shared-data keys ``<block>.<N>.<rest>`` by ``<block>.<N>``.

    Parameters
    ----------
    shared : dict of str to str
        The parsed ``shared-data/header.properties``.

    Returns
    -------
    dict of str to dict of str to str
        ``{"lcd-info.0": {"channel.name": "height", ...}, ...}``; keys with fewer than three
        dotted parts (``lcd-infos.count``) are left out.
    """
    blocks: dict[str, dict[str, str]] = {}
    for key, value in shared.items():
        parts = key.split(".", 2)
        if len(parts) == 3:
            blocks.setdefault(f"{parts[0]}.{parts[1]}", {})[parts[2]] = value
    return blocks


def resolve_references(props: dict[str, str], blocks: dict[str, dict[str, str]]) -> dict[str, str]:
    """Copy the shared-data blocks a header refers to into the header.

    Parameters
    ----------
    props : dict of str to str
        A parsed header with reference keys ``<prefix>.<block>.*=<N>``.
    blocks : dict of str to dict of str to str
        The shared data grouped by :func:`group_blocks`.

    Returns
    -------
    dict of str to str
        ``props`` plus every ``<block>.<N>.<rest>`` of the shared data as ``<prefix>.<rest>``;
        keys already present in ``props`` win.

    Raises
    ------
    HeaderError
        When a referenced block ``<block>.<N>`` is absent from the shared data; the message
        names it.
    """
    out = dict(props)
    for key, number in props.items():
        if not key.endswith(_REFERENCE_SUFFIX) or "." not in key[:-2]:
            continue
        prefix, block = key[:-2].rsplit(".", 1)
        source = f"{block}.{number.strip()}"
        if source not in blocks:
            raise HeaderError(f"'{key}={number}' refers to '{source}.*', which the shared data "
                              "(shared-data/header.properties) lacks")
        for rest, value in blocks[source].items():
            out.setdefault(f"{prefix}.{rest}", value)
    return out


def get(props: dict[str, str], key: str) -> str:
    """``props[key]``; :class:`HeaderError` naming the key when it is missing."""
    try:
        return props[key]
    except KeyError:
        raise HeaderError(f"missing key '{key}'") from None


def number(props: dict[str, str], key: str, kind: type = float, *, default: str | None = None) -> float:
    """``props[key]`` as ``kind`` (float or int); ``default`` when absent, else :class:`HeaderError`."""
    text = get(props, key) if default is None else props.get(key, default)
    try:
        return kind(text)
    except ValueError:
        raise HeaderError(f"'{key}' is not {'a number' if kind is float else 'an integer'}: "
                          f"{text!r}") from None


def encoder_prefix(props: dict[str, str], channel: str) -> str:
    """``channel.<ch>.encoder.`` (shared-data layout) or ``channel.<ch>.data.encoder.`` (older files)."""
    old = f"channel.{channel}.data.encoder."
    return old if old + "type" in props else f"channel.{channel}.encoder."


def require_linear(props: dict[str, str], scaling: str) -> None:
    """Refuse a ``<scaling>type`` / ``<scaling>style`` other than linear offset-multiplier."""
    style = props.get(scaling + "style", "offsetmultiplier")
    kind = props.get(scaling + "type", "linear")
    if (style, kind) != ("offsetmultiplier", "linear"):
        raise HeaderError(f"{scaling}type={kind}, style={style}: only linear offsetmultiplier is supported")


def conversion_steps(props: dict[str, str], channel: str, slot: str) -> list[tuple[float, float]]:
    """(multiplier, offset) of every slot from the channel's base slot up to ``slot``.

    Parameters
    ----------
    props : dict of str to str
        A segment header with its ``lcd-info`` references resolved.
    channel : str
        Channel name, e.g. ``vDeflection``.
    slot : str
        The wanted calibration slot, e.g. ``force``; the chain follows ``base-calibration-slot``
        from it down to ``conversion-set.conversions.base``.

    Returns
    -------
    list of (float, float)
        The steps in the order they apply (base first); empty when ``slot`` is the base.

    Raises
    ------
    HeaderError
        When a slot on the way is not defined (the message lists the defined ones), loops, or is
        not linear.
    """
    conv = f"channel.{channel}.conversion-set."
    base = get(props, conv + "conversions.base")
    steps: list[tuple[float, float]] = []
    current, seen = slot, set()
    while current != base:
        key = f"{conv}conversion.{current}."
        if current in seen:
            raise HeaderError(f"channel '{channel}': calibration slots loop at '{current}'")
        seen.add(current)
        if props.get(key + "defined") == "false" or key + "base-calibration-slot" not in props:
            defined = [s for s in props.get(conv + "conversions.list", "").split()
                       if props.get(f"{conv}conversion.{s}.defined") == "true"]
            raise HeaderError(f"channel '{channel}' has no calibration slot '{current}' (needed for "
                              f"'{slot}'; defined slots: {', '.join(defined) or 'none'})")
        require_linear(props, key + "scaling.")
        steps.append((number(props, key + "scaling.multiplier"), number(props, key + "scaling.offset")))
        current = props[key + "base-calibration-slot"]
    return steps[::-1]


def convert(props: dict[str, str], channel: str, slot: str, base: FloatArray) -> FloatArray:
    """Base-slot values of ``channel`` converted to ``slot`` (see :func:`conversion_steps`)."""
    values = np.asarray(base, dtype=np.float64)
    for multiplier, offset in conversion_steps(props, channel, slot):
        values = values * multiplier + offset
    return values


def slot_unit(props: dict[str, str], channel: str, slot: str) -> str:
    """Unit the file gives for ``slot`` of ``channel`` (the encoder's unit for the base slot)."""
    conv = f"channel.{channel}.conversion-set."
    if slot == props.get(conv + "conversions.base"):
        return props.get(encoder_prefix(props, channel) + "scaling.unit.unit", "")
    key = f"{conv}conversion.{slot}.scaling.unit"
    return props.get(key + ".unit", props.get(key, ""))
