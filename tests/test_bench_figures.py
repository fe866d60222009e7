"""The README's benchmark figures are RESULTS.md's headlines, never typed by hand (benchmarks/results.py)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import results  # noqa: E402 (benchmarks/ is not a package: on the path above)


def test_the_readme_figures_are_what_results_md_says():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    found = re.search(r"<!-- begin bench-figures -->\n(.*?)<!-- end bench-figures -->", readme, re.S)
    assert found, "README.md has no bench-figures block"
    expected = results.readme_block((ROOT / "benchmarks" / "RESULTS.md").read_text(encoding="utf-8"))
    assert found.group(1) == expected, "run `make bench` (or the benchmark whose figures changed)"


def test_a_section_gives_its_headlines_with_its_date_and_machine(tmp_path, capsys):
    results.headline("tick 120 µs = 2.1× Ruckig")
    printed = capsys.readouterr().out.splitlines()
    path = tmp_path / "RESULTS.md"
    results.write_section("bench_x", "X: a benchmark", ["a table line", *printed], path)
    results.write_section("bench_y", "Y: no headline", ["just a table"], path)
    block = results.readme_block(path.read_text(encoding="utf-8"))
    lines = block.splitlines()
    assert len(lines) == 2 and lines[1] == "  - tick 120 µs = 2.1× Ruckig"
    assert lines[0].startswith("- **X: a benchmark** (`benchmarks/bench_x.py`, 20")
    assert f"× {len(results.os.sched_getaffinity(0))}):" in lines[0] and results.cpu_model() in lines[0]
    readme = tmp_path / "README.md"
    readme.write_text("intro\n<!-- begin bench-figures -->\nold\n<!-- end bench-figures -->\nend\n")
    assert results.write_readme(path, readme)
    assert (
        readme.read_text() == f"intro\n<!-- begin bench-figures -->\n{block}<!-- end bench-figures -->\nend\n"
    )
