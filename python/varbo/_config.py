"""How a configuration given from Python reaches the C++ side: YAML text and a name for messages.

A config is a dict (sent as JSON, which is YAML), a YAML string, or a path (str ending in .yaml/.yml, an existing
file, or os.PathLike). Errors then name the file, or ``<config dict>`` / ``<config string>``, with line:column.
"""
from __future__ import annotations

import json
import os
import re
from typing import Any, Tuple

_TOP_LEVEL_TASK = re.compile(r"^task\s*:", re.MULTILINE)
_TOP_LEVEL_PARAMETERS = re.compile(r"^parameters\s*:", re.MULTILINE)


def _plain(value: Any) -> Any:
    """NumPy arrays and scalars as lists and numbers, so json.dumps accepts them."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, tuple):
        return list(value)
    raise TypeError(f"cannot put a {type(value).__name__} into a varbo configuration")


def is_path(config: Any) -> bool:
    if isinstance(config, os.PathLike):
        return True
    if not isinstance(config, str) or "\n" in config or config.lstrip().startswith("{"):
        return False
    return config.endswith((".yaml", ".yml")) or os.path.isfile(config)


def _warn_label_choices(parameters: Any, what: str) -> None:
    """A categorical parameter's choices are labels: ``choices: [True, False]`` or ``[5, 10, 20]`` reach the
    objective as the str "true"/"false" or "5" (the YAML and CLI semantics, kept by a resumed study), where
    ``if p["use_ff"]`` is then always taken and ``p["n"] * 2`` is "55" (red team, session 24). Said once per
    parameter when the config is created from a dict."""
    if not isinstance(parameters, list):
        return
    import warnings
    for p in parameters:
        if not isinstance(p, dict) or p.get("type") != "categorical" or not isinstance(p.get("choices"), list):
            continue
        odd = [c for c in p["choices"] if not isinstance(c, str)]
        if odd:
            labels = ["true" if c is True else "false" if c is False else str(c) for c in odd]
            warnings.warn(
                f"<{what} dict>: categorical parameter {p.get('name')!r}: its choices are labels, so your function "
                f"receives {', '.join(repr(x) for x in labels[:3])}{', ...' if len(labels) > 3 else ''} (str), not "
                f"{', '.join(repr(c) for c in odd[:3])}{', ...' if len(odd) > 3 else ''}; write the choices as "
                f"strings and convert them in your function, or use an int parameter for numbers",
                UserWarning, stacklevel=4)


def to_yaml(config: Any, what: str = "config") -> Tuple[str, str]:
    """(YAML text, name for messages)."""
    if is_path(config):
        path = os.fspath(config)
        try:
            with open(path, encoding="utf-8") as f:
                return f.read(), path
        except OSError as e:
            from . import InputError
            raise InputError(f"{path}: cannot read the {what}: {e.strerror}") from None
    if isinstance(config, dict):
        _warn_label_choices(config.get("parameters"), what)
        try:
            return json.dumps(config, indent=2, default=_plain, ensure_ascii=False), f"<{what} dict>"
        except RecursionError:
            from . import ConfigError
            raise ConfigError(f"<{what} dict>: nested too deeply to be a varbo configuration") from None
        except TypeError as e:  # a key that is not a str/int/float/bool/None, a value of an unknown type
            raise TypeError(f"<{what} dict>: {e}") from None
    if isinstance(config, str):
        return config, f"<{what} string>"
    raise TypeError(f"{what}: expected a dict, a YAML string or a path, got {type(config).__name__}")


def has_task(yaml_text: str) -> bool:
    return bool(_TOP_LEVEL_TASK.search(yaml_text))


def has_parameters(yaml_text: str) -> bool:
    return bool(_TOP_LEVEL_PARAMETERS.search(yaml_text))
