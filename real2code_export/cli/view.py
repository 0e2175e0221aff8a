"""``view``: the object in a local web page with a slider per joint (or, with --screenshot,
a PNG of that page rendered in headless Chromium)."""

from __future__ import annotations

import contextlib
import math

from .options import EXIT_OK, model_help


def add_parsers(sub) -> None:
    s = sub.add_parser(
        "view", help="show an object in a local web page: a slider per joint, the joint axes")
    s.add_argument("input", help=model_help("the object's model file"))
    s.add_argument("--host", default="127.0.0.1", help="address to serve on (default: this "
                   "machine only)")
    s.add_argument("--port", type=int, default=8000, help="port (default 8000; 0: any free)")
    s.add_argument("--no-browser", action="store_true", help="do not open a browser")
    s.add_argument("--screenshot", metavar="PNG", help="instead of serving: render the page in "
                   "headless Chromium into this PNG and exit")
    s.add_argument("--pose", action="append", default=[], metavar="JOINT=VALUE",
                   help="with --screenshot: a joint's value, set through its slider (radians "
                   "or metres; '60deg' for degrees); repeat for several")
    s.add_argument("--size", default="640x480", help="with --screenshot: WIDTHxHEIGHT pixels")
    s.add_argument("--view", default="-30,25", help="with --screenshot: camera azimuth (from "
                   "the object's +x towards +y) and elevation, in degrees")
    s.add_argument("--panel", action="store_true", help="with --screenshot: show the sliders")
    s.add_argument("--no-axes", dest="axes", action="store_false",
                   help="with --screenshot: leave the joint axes out")
    s.set_defaults(func=cmd_view)


def _pose(items: list[str]) -> dict[str, float]:
    from ..errors import InputError

    out = {}
    for item in items:
        name, sep, text = item.partition("=")
        try:
            if not sep or not name:
                raise ValueError
            out[name] = math.radians(float(text[:-3])) if text.endswith("deg") else float(text)
        except ValueError:
            raise InputError(f"--pose {item!r}: expected JOINT=VALUE, e.g. door_hinge=1.05 or "
                             "door_hinge=60deg") from None
    return out


def _pair(text: str, sep: str, option: str, kind=float) -> tuple:
    from ..errors import InputError

    try:
        a, b = (kind(t) for t in text.split(sep))
    except ValueError:
        raise InputError(f"{option} {text!r}: expected two numbers separated by {sep!r}") \
            from None
    return a, b


def cmd_view(args) -> int:
    from ..viewer import screenshot, serve

    if args.screenshot:
        state = screenshot(args.input, args.screenshot, pose=_pose(args.pose),
                           size=_pair(args.size, "x", "--size", int),
                           view=_pair(args.view, ",", "--view"), panel=args.panel,
                           axes=args.axes)
        posed = ", ".join(f"{k} = {v:.4g}" for k, v in state["joints"].items())
        print(f"wrote {args.screenshot} ({posed or 'no movable joints'})")
        return EXIT_OK
    if args.pose:
        from ..errors import InputError

        raise InputError("--pose needs --screenshot (in the page, use its sliders)")
    with contextlib.suppress(KeyboardInterrupt):  # Ctrl-C is how a person stops it
        serve(args.input, args.host, args.port, open_browser=not args.no_browser)
    return EXIT_OK
