"""A cable a test can cut: the network between tagwall and a server it needs."""

from __future__ import annotations

import contextlib
import socket
import threading
from urllib.parse import urlsplit

import pytest


class Cable:
    """A TCP link to a server (Redis, the test OpenID Provider) that a test cuts and
    mends, as a network (or the server's restart) would: cutting drops every connection
    through it, and while cut it takes new ones and drops them at once (counting them, so
    a test can tell its client kept trying).
    """

    def __init__(self, target_url: str) -> None:
        target = urlsplit(target_url)
        if target.hostname is None or target.port is None:
            pytest.skip(f"{target_url} is not on TCP")
        self._target = (target.hostname, target.port)
        self._parts = target
        self._sockets: set[socket.socket] = set()
        self._guard = threading.Lock()
        self._connected = True
        self.dropped = 0
        self._listener = socket.create_server(("127.0.0.1", 0))
        self._listener.settimeout(0.05)
        self._open = True
        threading.Thread(target=self._accept, daemon=True).start()

    @property
    def url(self) -> str:
        """The server's URL through this cable."""
        user = self._parts.netloc.rpartition("@")[0]
        address = f"127.0.0.1:{self._listener.getsockname()[1]}"
        return self._parts._replace(netloc=f"{user}@{address}" if user else address).geturl()

    def cut(self) -> None:
        with self._guard:
            self._connected = False
            for connection in self._sockets:
                _drop(connection)
            self._sockets.clear()

    def mend(self) -> None:
        with self._guard:
            self._connected = True

    def close(self) -> None:
        self.cut()
        self._open = False

    def _accept(self) -> None:
        while self._open:
            try:
                client, _ = self._listener.accept()
            except TimeoutError:
                continue
            with self._guard:
                if not self._connected:
                    self.dropped += 1
                    _drop(client)
                    continue
                try:
                    upstream = socket.create_connection(self._target)
                except OSError:  # the server is not there (yet, or any more)
                    _drop(client)
                    continue
                self._sockets |= {client, upstream}
            for source, sink in ((client, upstream), (upstream, client)):
                threading.Thread(target=_pipe, args=(source, sink), daemon=True).start()
        self._listener.close()


def _pipe(source: socket.socket, sink: socket.socket) -> None:
    try:
        while data := source.recv(65536):
            sink.sendall(data)
    except OSError:
        pass
    _drop(source)
    _drop(sink)


def _drop(connection: socket.socket) -> None:
    with contextlib.suppress(OSError):
        connection.shutdown(socket.SHUT_RDWR)
    connection.close()
