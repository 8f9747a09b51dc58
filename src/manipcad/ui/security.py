"""Who may talk to ``manipcad ui``: loopback by default, a token for anything else.

:class:`TokenGate` is an ASGI middleware around the whole application (pages,
static files, uploads and the websocket): every request must carry the token,
as ``?token=T`` (the link printed at start; the gate then sets a cookie so the
page's own requests carry it), a ``manipcad_token`` cookie, or an
``X-Manipcad-Token`` header. Without it: HTTP 401, or the websocket is closed.

:class:`HostCheck` guards a server on 127.0.0.1 without a token against DNS
rebinding (a web page whose own name the attacker points at 127.0.0.1, which the
browser then treats as that page's origin): a request whose ``Host`` is not a
loopback name (127.0.0.1, localhost, ::1, any port) gets HTTP 403, or the
websocket is closed.

:class:`BodyCap` caps every HTTP request's body (uploads: the upload field's own
limit is the browser's only): a larger declared ``Content-Length`` gets HTTP 413
before the application reads a byte, and a body sent without one is cut off with
413 once it passes the cap, so an upload never fills the server's memory or disk.
"""

from __future__ import annotations

import ipaddress
import secrets
from http.cookies import SimpleCookie
from urllib.parse import parse_qs

COOKIE = "manipcad_token"
#: bytes an upload's multipart body may hold beyond the file (boundaries, part headers)
MULTIPART_SLACK = 64 * 1024
HEADER = b"x-manipcad-token"


def is_loopback(host: str) -> bool:
    """Whether ``host`` only accepts connections from this machine.

    Example:
        >>> is_loopback("127.0.0.1"), is_loopback("localhost"), is_loopback("0.0.0.0")
        (True, True, False)
    """
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def token_for(host: str, token: str | None) -> str | None:
    """The token the server requires: the one given; else a new one when ``host`` is
    not loopback; else None (no token on 127.0.0.1).

    Example:
        >>> token_for("127.0.0.1", None) is None, token_for("127.0.0.1", "abc")
        (True, 'abc')
        >>> len(token_for("0.0.0.0", None)) >= 32
        True
    """
    if token:
        return token
    return None if is_loopback(host) else secrets.token_urlsafe(24)


async def refuse(scope, send, status: int, text: str, *, close: bool = False) -> None:
    """Answer a request with ``status`` and a plain-text body (a websocket: closed, code
    1008); ``close`` asks the client to drop the connection (a body not read)."""
    if scope["type"] == "websocket":
        await send({"type": "websocket.close", "code": 1008})
        return
    body = text.encode()
    headers = [(b"content-type", b"text/plain; charset=utf-8"),
               (b"content-length", str(len(body)).encode())]
    if close:
        headers.append((b"connection", b"close"))
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


class TokenGate:
    """ASGI middleware refusing every request without the token (see the module docstring).

    Args:
        app: the ASGI application.
        token: the token required.
    """

    def __init__(self, app, token: str) -> None:
        self.app = app
        self.token = token

    def _given(self, scope) -> tuple[str, bool]:
        qs = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        if qs.get("token"):
            return qs["token"][0], True
        for key, value in scope.get("headers", ()):
            if key == HEADER:
                return value.decode("latin-1"), False
            if key == b"cookie":
                jar = SimpleCookie()
                try:
                    jar.load(value.decode("latin-1"))
                except Exception:  # noqa: BLE001  a malformed cookie is no token
                    continue
                if COOKIE in jar:
                    return jar[COOKIE].value, False
        return "", False

    async def __call__(self, scope, receive, send):
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        given, in_query = self._given(scope)
        if not secrets.compare_digest(given.encode(), self.token.encode()):
            return await refuse(scope, send, 401, "manipcad ui: a token is required (open "
                                "the link printed at start)\n")
        if not (in_query and scope["type"] == "http"):
            return await self.app(scope, receive, send)

        async def send_with_cookie(message):
            if message["type"] == "http.response.start":
                cookie = f"{COOKIE}={self.token}; Path=/; HttpOnly; SameSite=Strict"
                message = {**message, "headers": [*message.get("headers", ()),
                                                  (b"set-cookie", cookie.encode())]}
            await send(message)

        return await self.app(scope, receive, send_with_cookie)


def host_name(host_header: str) -> str:
    """The name of a ``Host`` header without its port (IPv6 brackets kept off).

    Example:
        >>> host_name("127.0.0.1:8080"), host_name("[::1]:8080"), host_name("localhost")
        ('127.0.0.1', '::1', 'localhost')
    """
    h = host_header.strip().lower()
    if h.startswith("["):
        return h[1:h.find("]")] if "]" in h else h[1:]
    return h.rsplit(":", 1)[0] if h.count(":") == 1 else h


class HostCheck:
    """ASGI middleware refusing requests whose ``Host`` is not a loopback name (403; the
    websocket closed): on 127.0.0.1 without a token this is what keeps another web site
    from reaching the application by DNS rebinding (see the module docstring).

    Args:
        app: the ASGI application.
    """

    def __init__(self, app) -> None:
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        given = ""
        for key, value in scope.get("headers", ()):
            if key == b"host":
                given = value.decode("latin-1")
                break
        if is_loopback(host_name(given)):
            return await self.app(scope, receive, send)
        return await refuse(scope, send, 403, f"manipcad ui: Host {given!r} refused; open "
                            "http://127.0.0.1:PORT/ (another name needs --host and a token)\n")


class _TooLarge(Exception):
    """A request body passed :class:`BodyCap`'s limit while it was being read."""


class BodyCap:
    """ASGI middleware refusing HTTP request bodies larger than ``limit`` bytes (413).

    Args:
        app: the ASGI application.
        limit: the largest body accepted, bytes (an upload's multipart body is the file
            plus a few hundred bytes of headers).
    """

    def __init__(self, app, limit: int) -> None:
        self.app = app
        self.limit = int(limit)

    async def _refuse(self, scope, send, size: str) -> None:
        await refuse(scope, send, 413, f"manipcad ui: request body {size}larger than the "
                     f"{self.limit} bytes accepted\n", close=True)

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        for key, value in scope.get("headers", ()):
            if key == b"content-length":
                try:
                    declared = int(value)
                except ValueError:
                    declared = self.limit + 1
                if declared > self.limit:
                    return await self._refuse(scope, send,
                                              f"of {value.decode('latin-1')} bytes: ")
        seen = 0
        started = False

        async def counted():
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > self.limit:
                    raise _TooLarge
            return message

        async def watched(message):
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        try:
            return await self.app(scope, counted, watched)
        except _TooLarge:
            if not started:
                await self._refuse(scope, send, "")
            return None


#: what starlette's ``BaseHTTPMiddleware`` (NiceGUI's own middlewares) raises when the
#: application below it ends a request without a response, as a file response does when
#: the browser has gone (a page left while its scripts and fonts were loading)
NO_RESPONSE = "No response returned."


class QuietDisconnect:
    """The outermost ASGI layer: a request whose browser went away before the answer (it
    sent ``http.disconnect``) and that the layers below then end with starlette's "No
    response returned." RuntimeError ends quietly; there is no one to answer. Every other
    exception, and that one for a client still there, goes on to the server as before.

    Without it, leaving a page before it had loaded logged one "Exception in ASGI
    application" traceback per file request cut short. ``manipcad ui`` wraps the whole
    application in it (outside NiceGUI's own middlewares).

    Args:
        app: the ASGI application.
    """

    def __init__(self, app) -> None:
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        gone = False

        async def watched():
            nonlocal gone
            message = await receive()
            if message["type"] == "http.disconnect":
                gone = True
            return message

        try:
            return await self.app(scope, watched, send)
        except RuntimeError as exc:
            if gone and str(exc) == NO_RESPONSE:
                return None
            raise


def quiet_disconnects(app) -> None:
    """Wrap the whole middleware stack of the (FastAPI) ``app`` in
    :class:`QuietDisconnect` when the stack is built (at its first request; NiceGUI adds
    its own middlewares when it starts, so ``add_middleware`` would put this inside them)."""
    build = app.build_middleware_stack

    def built():
        return QuietDisconnect(build())

    app.build_middleware_stack = built
