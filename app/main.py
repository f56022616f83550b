"""`skel-inspect [INPUT] [--host 127.0.0.1] [--port 8080]`: serve the inspector on one cloud."""
from __future__ import annotations

import argparse
import socket
import sys
import threading
from pathlib import Path

from skelcore.errors import SkelError
from skelcore.api import load
from skelcore.io import Cloud, validate
from skelcore.params import ContractionParams
from skelcore.shapes import make_shape

from .session import Session, bundled_assets

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


def serve(cloud: Cloud, host: str, port: int, *, save_dir: Path | None = None,
          params: ContractionParams = ContractionParams(), verbose: bool = False, **session_options):
    """Start a server and an inspector on `cloud`; returns (server, inspector). The caller stops them.
    session_options: label_weights, weights, history (see app.session.Session)."""
    import viser

    from .inspector import Inspector

    session = Session(cloud, params, **session_options)
    server = viser.ViserServer(host=host, port=port, verbose=verbose)
    inspector = Inspector(server, session, assets=bundled_assets(), save_dir=save_dir)
    return server, inspector


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="skel-inspect", description=__doc__.split(":", 1)[1].strip())
    parser.add_argument("input", nargs="?", help="point cloud or mesh (default: a bundled asset)")
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1: this machine only)")
    parser.add_argument("--port", type=int, default=8080, help="port (the next free one is taken if busy)")
    parser.add_argument("--save-dir", type=Path, help="where 'Also save on server' writes screenshots and bundles")
    args = parser.parse_args(argv)
    problem = host_problem(args.host)
    if not 0 <= args.port <= 65535:
        problem = f"--port {args.port}: must be between 0 and 65535"
    if problem:
        print(f"skel-inspect: {problem}", file=sys.stderr)
        return 2
    try:
        cloud = load(args.input) if args.input else default_cloud(bundled_assets())
        server, inspector = serve(cloud, args.host, args.port, save_dir=args.save_dir)
    except SkelError as error:
        print(f"skel-inspect: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"skel-inspect: cannot serve on {args.host}:{args.port} ({error.strerror or error})", file=sys.stderr)
        return 2
    print(f"skel-inspect: {Path(cloud.name).name} ({len(cloud.points):,} points) at "
          f"http://{args.host}:{server.get_port()}  (Ctrl+C to stop)", flush=True)
    try:
        threading.Event().wait()
    except KeyboardInterrupt:
        pass
    finally:
        inspector.close()
        server.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
