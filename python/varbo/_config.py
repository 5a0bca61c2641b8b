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
        try:
            return json.dumps(config, indent=2, default=_plain), f"<{what} dict>"
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
