"""`skel-inspect [INPUT] [--host HOST] [--port PORT]`: serve the inspector on one cloud.

Guarded as Jupyter guards its server: it listens on this machine only unless told otherwise. Bound to
any other address it prints a warning, and the page and its websocket then require a token, printed in
the URL (`?token=...`; the page's response sets it as a cookie, which the websocket then carries).
`--no-token` turns the token off, explicitly.
"""
from __future__ import annotations

import hmac
import http
import http.cookies
import ipaddress
import secrets
import socket
import sys
import threading
import urllib.parse
from pathlib import Path

from skelcore.cli import OneLineParser
from skelcore.errors import SkelError, TooLargeError
from skelcore.io import FORMATS, Cloud, check_sampling, load, validate
from skelcore.paths import writable_folder
from skelcore.memory import INSPECTOR_SHARE, budget_bytes
from skelcore.params import ContractionParams
from skelcore.shapes import make_shape

from .session import Session

LOCAL_HOST = "127.0.0.1"  # the address served by default: this machine only
PORT = 8080  # the port asked for by default (the next free one is taken if busy)

DEFAULT_ASSETS = ("torus.ply", "y_branch.ply")  # first that exists is opened when no INPUT is given
FALLBACK_SHAPE = ("torus", 3000)  # synthesised when assets/ holds nothing


def default_cloud(assets: dict[str, Path]) -> Cloud:
    for name in (*DEFAULT_ASSETS, *assets):
        if name in assets:
            return load(assets[name])
    shape = make_shape(FALLBACK_SHAPE[0], FALLBACK_SHAPE[1])
    return validate(shape.points, name=f"{shape.name}-synthetic")


def host_problem(host: str) -> str | None:
    """Why the server cannot listen on `host` (checked first: viser retries a failing bind forever)."""
    try:
        family, kind, _, _, address = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)[0]
        with socket.socket(family, kind) as probe:
            probe.bind(address)
    except OSError as error:
        return f"--host {host}: cannot listen there ({error.strerror or error})"
    return None


def is_loopback(host: str) -> bool:
    """Whether every address `host` names is on this machine only."""
    try:
        addresses = {info[4][0] for info in socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)}
        return all(ipaddress.ip_address(address.split("%")[0]).is_loopback for address in addresses)
    except (OSError, ValueError):
        return False


def token_gate(token: str, cookie: str):
    """A websockets `process_request` wrapper: requests without the token (in the URL's query or the
    cookie the page's response set) are answered 403, and a websocket must come from the page's origin."""
    def wrap(inner):
        def process_request(connection, request):
            query = urllib.parse.parse_qs(urllib.parse.urlsplit(request.path).query)
            given = (query.get("token") or [""])[0]
            jar = http.cookies.SimpleCookie()
            try:
                jar.load(request.headers.get("Cookie", ""))
            except http.cookies.CookieError:
                pass
            kept = jar[cookie].value if cookie in jar else ""
            by_query = hmac.compare_digest(given.encode(), token.encode())
            if not (by_query or hmac.compare_digest(kept.encode(), token.encode())):
                return connection.respond(http.HTTPStatus.FORBIDDEN,
                                          "skel-inspect: open the URL with the token the server printed\n")
            origin = request.headers.get("Origin")
            if (request.headers.get("Upgrade", "").lower() == "websocket" and origin
                    and urllib.parse.urlsplit(origin).netloc != request.headers.get("Host")):
                return connection.respond(http.HTTPStatus.FORBIDDEN, "skel-inspect: cross-origin websocket\n")
            response = inner(connection, request) if inner is not None else None
            if by_query and response is not None:
                response.headers["Set-Cookie"] = f"{cookie}={token}; Path=/; HttpOnly; SameSite=Strict"
            return response
        return process_request
    return wrap


_SERVER_START = threading.Lock()


def viser_server(host: str, port: int, *, token: str | None = None, verbose: bool = False):
    """A viser server whose every request passes `token_gate` when a token is given.

    viser hands its HTTP handler to websockets' `serve` inside its server thread and offers no way in;
    `serve` is wrapped while (and only while) this server starts, under a lock."""
    import viser
    import websockets.asyncio.server as websockets_server

    if token is None:
        return viser.ViserServer(host=host, port=port, verbose=verbose)
    with _SERVER_START:
        original = websockets_server.serve

        def serve(handler, *args, process_request=None, **kwargs):
            cookie = f"skel_inspect_token_{args[1] if len(args) > 1 else kwargs.get('port', port)}"
            return original(handler, *args, process_request=token_gate(token, cookie)(process_request), **kwargs)

        websockets_server.serve = serve
        try:
            return viser.ViserServer(host=host, port=port, verbose=verbose)
        finally:
            websockets_server.serve = original


def serve(cloud: Cloud, host: str, port: int, *, save_dir: Path | None = None,
          params: ContractionParams = ContractionParams(), verbose: bool = False, token: str | None = None,
          **session_options):
    """Start a server and an inspector on `cloud`; returns (server, inspector). The caller stops them.
    With a token, every page and websocket request must carry it. session_options: label_weights, weights,
    history, point_budget, look_ahead (see app.session.Session)."""
    from .inspector import Inspector

    session = Session(cloud, params, **session_options)
    server = viser_server(host, port, token=token, verbose=verbose)
    inspector = Inspector(server, session, assets=bundled_assets(), save_dir=save_dir)
    return server, inspector


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(prog="skel-inspect", description=__doc__.split(":", 1)[1].strip())
    parser.add_argument("input", nargs="?", help="point cloud or mesh (default: a bundled asset)")
    parser.add_argument("--host", default=LOCAL_HOST, help="address to bind (default %(default)s: this machine only)")
    parser.add_argument("--port", type=int, default=PORT,
                        help="port (default %(default)s; the next free one is taken if busy)")
    parser.add_argument("--save-dir", type=Path, help="where 'Also save on server' writes screenshots and bundles")
    parser.add_argument("--voxel-size", type=float, help="downsample INPUT to one point per voxel of this size "
                                                         "(for a cloud over the inspector's memory budget)")
    parser.add_argument("--sample", type=int, help="for a mesh INPUT: draw this many points evenly over its surface; "
                                                   "0: its vertices (default: its vertices where they cover its "
                                                   "surface, else points drawn evenly)")
    parser.add_argument("--full-resolution", action="store_true",
                        help="contract every point, even above the point budget or in dense parts (slower on large "
                             "clouds)")
    parser.add_argument("--no-look-ahead", action="store_true",
                        help="do not compute the next iteration while the run waits for Step (saves the CPU on a "
                             "shared machine; each Step then takes the whole step's time)")
    parser.add_argument("--no-token", action="store_true",
                        help="serve a non-loopback --host without a token: anyone who can reach it can drive the "
                             "session, upload files and write into --save-dir")
    args = parser.parse_args(argv)
    problem = host_problem(args.host)
    if not 0 <= args.port <= 65535:
        problem = f"--port {args.port}: must be between 0 and 65535"
    if problem:
        print(f"skel-inspect: {problem}", file=sys.stderr)
        return 2
    exposed = not is_loopback(args.host)
    token = secrets.token_urlsafe(24) if exposed and not args.no_token else None
    if exposed:
        print(f"skel-inspect: warning: --host {args.host} is reachable from other machines; "
              + ("anyone who reaches it can drive the session (--no-token)" if token is None else
                 "the page and its websocket require the token in the URL below"), file=sys.stderr, flush=True)
    try:
        check_sampling(sample=args.sample, voxel_size=args.voxel_size)  # without INPUT too: never silently dropped
        if args.save_dir is not None:  # checked before serving: a click on "Also save on server" is too late
            writable_folder(args.save_dir, "--save-dir")
        cloud = (load(args.input, sample=args.sample, voxel_size=args.voxel_size,
                      budget=budget_bytes(INSPECTOR_SHARE)) if args.input
                 else default_cloud(bundled_assets()))
        for note in cloud.notes:  # what loading did (a mesh's surface sampled, repeats removed), as `skelcore run`
            print(f"skel-inspect: {Path(cloud.name).name}: {note}", flush=True)
        server, inspector = serve(cloud, args.host, args.port, save_dir=args.save_dir, token=token,
                                  look_ahead=not args.no_look_ahead,
                                  **({"point_budget": None} if args.full_resolution else {}))
    except SkelError as error:
        advice = f" (--voxel-size {error.voxel_size:g})" if isinstance(error, TooLargeError) else ""
        print(f"skel-inspect: {error}{advice}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"skel-inspect: cannot serve on {args.host}:{args.port} ({error.strerror or error})", file=sys.stderr)
        return 2
    shown_host = socket.gethostname() if args.host in ("0.0.0.0", "::", "") else args.host
    query = f"/?token={token}" if token else ""
    print(f"skel-inspect: {Path(cloud.name).name} ({len(cloud.points):,} points) at "
          f"http://{shown_host}:{server.get_port()}{query}  (Ctrl+C to stop)", flush=True)
    try:
        threading.Event().wait()
    except KeyboardInterrupt:
        pass
    finally:
        inspector.close()
        server.stop()
    return 0


def bundled_assets(directory: Path | None = None) -> dict[str, Path]:
    """Shape files shipped in assets/, by file name."""
    directory = directory or Path(__file__).resolve().parents[1] / "assets"
    if not directory.is_dir():
        return {}
    return {path.name: path for path in sorted(directory.iterdir())
            if path.is_file() and path.suffix.lower() in FORMATS}


if __name__ == "__main__":
    sys.exit(main())
