"""Logging without secrets: tokens in URLs never reach a log file.

Tile URLs and the operator's sign-in link carry their token in the query string (and a
campus provider's answer its sign-in ``code``), and
every request's path is logged (tagwall's own access log, :data:`ACCESS_LOGGER`, which
masks them as it writes the line), as uvicorn logs every websocket's (error log).
:class:`RedactSecrets` masks them on the handlers, whatever logger the line came from.
"""

from __future__ import annotations

import copy
import logging
import re
from typing import Any

_SECRET_QUERY = re.compile(r"((?:^|[?&;\s])(?:token|csrf|code)=)[^&;\s\"']+", re.IGNORECASE)
REDACTED = "[redacted]"
ACCESS_LOGGER = "tagwall.access"  # one line per HTTP response (webapp.web.middleware)


def redact(text: str) -> str:
    """``text`` with the values of ``token=``, ``csrf=`` and ``code=`` query parameters
    masked."""
    return _SECRET_QUERY.sub(rf"\g<1>{REDACTED}", text)


class RedactSecrets(logging.Filter):
    """Masks secrets in a record's message and its string arguments (uvicorn's access
    formatter reads the arguments one by one, so they are masked in place)."""

    def filter(self, record: logging.LogRecord) -> bool:
        if isinstance(record.msg, str):
            record.msg = redact(record.msg)
        if isinstance(record.args, tuple):
            record.args = tuple(redact(a) if isinstance(a, str) else a for a in record.args)
        return True


def uvicorn_log_config() -> dict[str, Any]:
    """uvicorn's logging configuration with :class:`RedactSecrets` on its handlers, and
    tagwall's access log in place of uvicorn's (run it with ``access_log=False``): its
    lines come masked and formatted, so they are written as they come."""
    from uvicorn.config import LOGGING_CONFIG

    config: dict[str, Any] = copy.deepcopy(LOGGING_CONFIG)
    # uvicorn's formatters copy each record to colour it: a plain one, in uvicorn's columns
    config["formatters"]["access_line"] = {"format": "%(levelname)s:     %(message)s"}
    config["handlers"]["access_line"] = {
        "formatter": "access_line",
        "class": "logging.StreamHandler",
        "stream": "ext://sys.stdout",
    }
    config["loggers"][ACCESS_LOGGER] = {
        "handlers": ["access_line"],
        "level": "INFO",
        "propagate": False,
    }
    config.setdefault("filters", {})["redact_secrets"] = {"()": f"{__name__}.RedactSecrets"}
    for name, handler in config["handlers"].items():
        if name != "access_line":  # masked as the middleware makes it (one regex, not two)
            handler.setdefault("filters", []).append("redact_secrets")
    return config


def redact_root_handlers() -> None:
    """Mask secrets in what tagwall's own loggers write, too."""
    for handler in logging.getLogger().handlers:
        if not any(isinstance(f, RedactSecrets) for f in handler.filters):
            handler.addFilter(RedactSecrets())
