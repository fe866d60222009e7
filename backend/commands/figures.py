"""`nutty figures OUT_DIR`: regenerate the paper's NMF figures from the filter itself."""

from __future__ import annotations

from pathlib import Path

from backend.commands._common import fail


def register(sub) -> None:
    p = sub.add_parser(
        "figures",
        help="regenerate the paper's motion-filter figures (PNG)",
        description="Draw the NMF figures of the paper (inputs, H, Ω, presets, orders) from the "
        "filter itself into OUT_DIR.",
    )
    p.add_argument("out_dir", nargs="?", default="docs/figures", help="output folder (default docs/figures)")
    p.set_defaults(func=run)


def run(args) -> int:
    from backend.engine.nmf_figures import draw_all  # lazy: a fast `nutty --help`

    out = Path(args.out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return fail(f"cannot create '{out}': {exc.strerror}")
    for path in draw_all(out):
        print(path)
    return 0
