"""Reading a sweep file: YAML 1.2 numbers, unique keys, and bounds on its size and
nesting, checked before anything walks or prints it."""

from __future__ import annotations

import re
import stat
from pathlib import Path
from typing import Mapping

import yaml

from fcsweep.config.errors import ConfigError, show_value

#: A sweep file is at most this large (bytes) ...
MAX_CONFIG_BYTES = 1 << 20
#: ... nests at most this deep (a sweep needs 4 levels: top, grid, key, range) ...
MAX_NESTING = 16
#: ... and holds at most this many values once YAML aliases are expanded.
MAX_VALUES = 200_000


class UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that rejects duplicate mapping keys instead of keeping the last."""


def _construct_mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        try:
            hash(key)
        except TypeError:
            raise ConfigError(
                f"complex key {_source_text(key_node)} "
                f"(line {key_node.start_mark.line + 1}); "
                "keys must be plain names, not lists or mappings"
            ) from None
        if key in seen:
            raise ConfigError(
                f"duplicate key {show_value(key)} (line {key_node.start_mark.line + 1}); "
                "each key may appear once per section"
            )
        seen.add(key)
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


def _source_text(node) -> str:
    """The YAML text of a node, on one line and cut short."""
    start, end = node.start_mark, node.end_mark
    text = " ".join(str(start.buffer or "")[start.index:end.index].split())
    return text if len(text) <= 60 else text[:57] + "..."


UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def _construct_int(loader, node):
    try:
        return yaml.SafeLoader.construct_yaml_int(loader, node)
    except ValueError:  # more digits than int() converts (sys.get_int_max_str_digits)
        raise ConfigError(f"the integer at line {node.start_mark.line + 1} has {len(node.value)} digits; "
                          "no setting takes more than 20") from None



# Numbers as YAML 1.2 (core schema) and Python read them.  PyYAML follows YAML 1.1, where
# a float needs a dot and a signed exponent: there ``5e-3``, ``1E-2``, ``1e3`` and ``2.0e3``
# are strings.  Added here: a decimal with an exponent, sign optional -- exactly what
# Python's float() accepts (``_`` only between digits) -- and ``0o17`` octal (YAML 1.2,
# Python).  ``017`` is 17 (YAML 1.2) and not 15 (YAML 1.1 octal).  Everything YAML 1.1
# already reads as a number (``.inf``, ``1_000``, ``0x1f``, ``0b101``) reads as before.
_DIGITS = r"[0-9](?:_?[0-9])*"
_EXPONENT_FLOAT = re.compile(
    rf"^[-+]?(?:{_DIGITS}(?:\.(?:{_DIGITS})?)?|\.{_DIGITS})[eE][-+]?{_DIGITS}$")
_OCTAL_12 = re.compile(r"^[-+]?0o[0-7](?:_?[0-7])*$")
UniqueKeyLoader.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+.0123456789"))
UniqueKeyLoader.add_implicit_resolver("tag:yaml.org,2002:int", _OCTAL_12, list("-+0"))


def _construct_int_12(loader, node):
    text = str(node.value)
    digits = text.lstrip("+-").replace("_", "")
    if _OCTAL_12.match(text) or (len(digits) > 1 and digits[0] == "0" and digits.isdigit()):
        sign = -1 if text.startswith("-") else 1
        base = 8 if _OCTAL_12.match(text) else 10
        body = digits[2:] if base == 8 else digits
        if len(body) > 4300:
            return _construct_int(loader, node)  # the digit-limit message
        return sign * int(body, base)
    return _construct_int(loader, node)


UniqueKeyLoader.add_constructor("tag:yaml.org,2002:int", _construct_int_12)


def read_text(path: Path) -> str:
    """The text of a sweep file: a regular file of at most MAX_CONFIG_BYTES of UTF-8."""
    try:
        st = path.stat()
        if not stat.S_ISREG(st.st_mode):
            kind = "a directory" if stat.S_ISDIR(st.st_mode) else "not a regular file"
            raise ConfigError(f"config file {str(path)!r} is {kind}")
        if st.st_size > MAX_CONFIG_BYTES:
            raise ConfigError(f"config file {str(path)!r} has {st.st_size} bytes; a sweep file has at most "
                              f"{MAX_CONFIG_BYTES}")
        with open(path, "rb") as fh:
            raw = fh.read(MAX_CONFIG_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"cannot read config file {str(path)!r}: {exc.strerror or exc}") from None
    except ValueError as exc:  # e.g. a NUL byte in the path
        raise ConfigError(f"cannot read config file {str(path)!r}: {exc}") from None
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise ConfigError(f"{path}: not UTF-8 text: byte 0x{raw[exc.start]:02x} at line {line} "
                          f"(offset {exc.start}); save the file as UTF-8") from None


def check_structure(data) -> None:
    """Refuse YAML whose values nest too deeply, expand (through aliases) to too many
    values, or contain themselves -- before anything walks or prints them."""
    sizes: dict[int, int] = {}

    def size(node, depth: int, path: str) -> int:
        if not isinstance(node, (Mapping, list, set)):
            return 1
        if depth > MAX_NESTING:
            raise ConfigError(f"{path or 'the file'} nests more than {MAX_NESTING} levels deep; "
                              "a sweep file needs at most 4")
        key = id(node)
        if key in sizes:
            if sizes[key] < 0:
                raise ConfigError(f"{path} contains itself (a YAML alias inside its own anchor)")
            return sizes[key]
        sizes[key] = -1
        items = node.items() if isinstance(node, Mapping) else enumerate(node)
        total = 1
        for k, v in items:
            total += size(v, depth + 1, f"{path}.{k}" if path else str(k))
            if total > MAX_VALUES:
                raise ConfigError(f"{path or 'the file'} holds more than {MAX_VALUES} values (YAML aliases "
                                  "expanded); a sweep file is far smaller")
        sizes[key] = total
        return total

    size(data, 0, "")
