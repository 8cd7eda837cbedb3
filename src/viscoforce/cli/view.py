"""``viscoforce view``: an interactive viewer of a fitted map, as one HTML file or served locally.

``view FITS.nc [--data SPECTRA.nc] --out report.html`` writes the page of
:mod:`viscoforce.plotting.viewer` (Bokeh's JavaScript inline: it opens from a ``file://`` URL with
no network); ``--serve`` serves the same page on 127.0.0.1 (a free port unless ``--port``),
prints its URL and runs until Ctrl-C. The server answers only requests addressed to it by its
loopback name and port (the ``Host`` header: a page of another site reaching 127.0.0.1 through
DNS rebinding gets 421) and sends the page's Content-Security-Policy as a header too
(docs/security.md).
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path
from typing import Any

from viscoforce.cli._args import Output, UsageError, add_outputs, integer_type
from viscoforce.cli._output import print_json, print_written

__all__ = ["SUBCOMMANDS", "add_view", "run_view", "serve_html"]

#: Where ``--serve`` listens (loopback only: the page is never offered to the network).
HOST = "127.0.0.1"
#: The host names ``--serve`` answers to (with its port; any other ``Host`` header gets 421).
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")
#: The kind of ``--out`` (checked for a writable place by ``check_outputs``; ``.html`` here).
HTML = "html"


def add_view(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce view``."""
    parser.add_argument("fits", metavar="FITS.nc",
                        help="a fitted map ('viscoforce fit MAP --out fits.nc')")
    parser.add_argument("--data", metavar="SPECTRA.nc", default=None,
                        help="the map's spectra ('viscoforce load MAP --out spectra.nc', or the "
                             "map file itself): the data of each pixel's Bode plot")
    add_outputs(parser, [Output("--out", HTML, "REPORT.html",
                                "write the viewer as one self-contained HTML file")])
    parser.add_argument("--serve", action="store_true",
                        help=f"serve the viewer on {HOST} (a free port, printed) until Ctrl-C")
    parser.add_argument("--port", type=integer_type(0), default=None, metavar="PORT",
                        help="port of --serve (default: a free one)")
    parser.add_argument("--json", action="store_true",
                        help="print what was written or served as one JSON object")


def _open_netcdf(flag: str, path: str):
    from viscoforce.exceptions import EffortError
    from viscoforce.io.netcdf import open_netcdf

    if not Path(path).is_file():
        raise UsageError(f"{flag} {path}: no such file")
    try:
        return open_netcdf(path)
    except EffortError as exc:
        raise UsageError(f"{flag} {exc}") from None
    except (OSError, ValueError) as exc:
        raise UsageError(f"{flag} {path}: not a readable netCDF file ({exc})") from None


def _spectra(path: str):
    """The spectra of ``--data``: a netCDF file as written by ``load``, or the map file."""
    if Path(path).suffix.lower() == ".nc":
        return _open_netcdf("--data", path)
    if not Path(path).exists():
        raise UsageError(f"--data {path}: no such file")
    from viscoforce.cli.fitting import read_data

    return read_data(path)


def _check_flags(args: argparse.Namespace) -> None:
    if args.out is not None and args.serve:
        raise UsageError("give --out REPORT.html or --serve, not both (--out writes the page, "
                         "--serve serves it)")
    if args.out is None and not args.serve:
        raise UsageError("give --out REPORT.html (write the page) or --serve (serve it on "
                         f"{HOST})")
    if args.port is not None and not args.serve:
        raise UsageError("--port applies to --serve only")
    if args.port is not None and args.port > 65535:
        raise UsageError(f"--port must be in [0, 65535] (0: a free port), got {args.port}")
    if args.out is not None and Path(args.out).suffix.lower() not in (".html", ".htm"):
        raise UsageError(f"--out {args.out}: the page's file name must end in .html")


def run_view(args: argparse.Namespace) -> int:
    """Build the viewer page of FITS (and --data) and write it or serve it."""
    from viscoforce.exceptions import SchemaError
    from viscoforce.plotting.viewer import map_view, report_html

    _check_flags(args)
    fits = _open_netcdf("FITS", args.fits)
    spectra = None if args.data is None else _spectra(args.data)
    try:
        view = map_view(fits, spectra, title=f"{Path(args.fits).name}: "
                        f"{fits.attrs.get('model', 'fit')} model")
    except SchemaError as exc:
        raise UsageError(f"FITS {args.fits}: {exc}") from None
    html = report_html(view, csv_name=f"{Path(args.fits).stem}.csv")
    info: dict[str, Any] = {"fits": args.fits, "data": args.data, "pixels": view.n_pixels,
                            "params": list(view.params), "bytes": len(html.encode()),
                            "notes": list(view.notes)}
    if args.out is not None:
        from viscoforce._files import write_text

        write_text(args.out, html)
        info["out"] = args.out
        if args.json:
            print_json(info)
        else:
            for note in view.notes:
                print(f"note: {note}")
            print_written(args.out)
        return 0
    return serve_html(html, port=args.port or 0, info=info if args.json else None)


def serve_html(html: str, *, port: int = 0, info: dict[str, Any] | None = None) -> int:
    """Serve ``html`` at ``http://127.0.0.1:PORT/`` until Ctrl-C (KeyboardInterrupt); return 0.

    Only requests with one ``Host`` header naming this server (:data:`LOOPBACK_NAMES` with its
    port) are answered, others get 421 (DNS rebinding: another site's page reaching 127.0.0.1
    under its own name). Every response carries the page's Content-Security-Policy
    (:func:`viscoforce.plotting.viewer.content_security_policy`, plus ``frame-ancestors
    'none'``) and ``X-Content-Type-Options: nosniff``.

    Parameters
    ----------
    html : str
        The page.
    port : int
        The port (0: a free one, chosen by the system).
    info : dict, optional
        Print it with ``url`` added as one JSON line, instead of the plain URL line.
    """
    from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

    from viscoforce.plotting.viewer import content_security_policy

    body = html.encode()
    policy = f"{content_security_policy(html)}; frame-ancestors 'none'"
    hosts: set[str] = set()  # filled once the port is known

    class Handler(BaseHTTPRequestHandler):
        def end_headers(self) -> None:
            self.send_header("Content-Security-Policy", policy)
            self.send_header("X-Content-Type-Options", "nosniff")
            super().end_headers()

        def _send(self, status: int, content_type: str, content: bytes) -> None:
            self.send_response(status)
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(len(content)))
            self.end_headers()
            self.wfile.write(content)

        def do_GET(self) -> None:  # noqa: N802 - http.server's name
            names = self.headers.get_all("Host") or []
            if len(names) != 1 or names[0].strip().lower() not in hosts:
                self._send(421, "text/plain; charset=utf-8",
                           f"this server answers only at {url}\n".encode())
                return
            if self.path.split("?")[0] not in ("/", "/index.html"):
                self.send_error(404, "the viewer is at /")
                return
            self._send(200, "text/html; charset=utf-8", body)

        def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the base's name
            return  # quiet: the terminal shows the URL and how to stop

    try:
        server = ThreadingHTTPServer((HOST, port), Handler)
    except OSError as exc:
        raise UsageError(f"--port {port}: cannot listen on {HOST} ({exc.strerror})") from None
    url = f"http://{HOST}:{server.server_address[1]}/"
    hosts.update(f"{name}:{server.server_address[1]}" for name in LOOPBACK_NAMES)
    if info is not None:
        print_json({**info, "url": url})
    else:
        print(f"serving the viewer at {url} (Ctrl-C stops)")
    sys.stdout.flush()
    if threading.current_thread() is threading.main_thread():
        # Ctrl-C must stop it even when it was started with SIGINT ignored (a background job
        # of a shell script, a test runner's worker): Python then installs no handler itself
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        print("stopped", file=sys.stderr)
    finally:
        server.server_close()
    return 0


SUBCOMMANDS = {"view": (add_view, run_view)}
