#!/usr/bin/env python3
"""Shrinks fuzz/corpus/<target>/ to at most MAX files (default 150) that keep the most code
edges: libFuzzer's merge pass (edges only, `-use_counters=0`) records the edges of every
file, then a greedy set cover keeps the file adding the most uncovered edges (the smaller
on ties) until every edge is covered or MAX files are kept. `cargo fuzz cmin` keeps every
file that adds any feature (over a thousand after 2×10⁵ runs), too many to commit.

    cd fuzz && python3 minimise.py gltf [MAX]     # after `cargo +nightly fuzz build`

Run it with the same TMPDIR as the fuzzing (the file-based targets write scratch files).
"""

import os
import pathlib
import subprocess
import sys
import tempfile

FUZZ = pathlib.Path(__file__).resolve().parent


def main():
    target = sys.argv[1]
    cap = int(sys.argv[2]) if len(sys.argv) > 2 else 150
    target_dir = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", FUZZ / "target"))
    binary = target_dir / "x86_64-unknown-linux-gnu/release" / target
    corpus = FUZZ / "corpus" / target
    with tempfile.TemporaryDirectory() as tmp:
        control = pathlib.Path(tmp) / "control"
        out = pathlib.Path(tmp) / "out"
        out.mkdir()
        subprocess.run(
            [str(binary), "-merge=1", "-use_counters=0", f"-merge_control_file={control}",
             "-rss_limit_mb=2048", "-timeout=10", str(out), str(corpus)],
            check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        lines = control.read_text().splitlines()
        n = int(lines[0])
        files = [pathlib.Path(p) for p in lines[2:2 + n]]
        edges = {}
        for line in lines[2 + n:]:
            parts = line.split()
            if parts and parts[0] == "COV":
                edges[int(parts[1])] = set(map(int, parts[2:]))
    total = set().union(*edges.values()) if edges else set()
    covered, keep = set(), []
    while len(keep) < cap:
        best = max(edges, key=lambda i: (len(edges[i] - covered), -files[i].stat().st_size),
                   default=None)
        if best is None or not edges[best] - covered:
            break
        covered |= edges.pop(best)
        keep.append(files[best])
    for f in corpus.iterdir():
        if f not in keep:
            f.unlink()
    size = sum(f.stat().st_size for f in keep)
    print(f"{target}: kept {len(keep)} of {n} files ({size} bytes), "
          f"{len(covered)} of {len(total)} edges")


if __name__ == "__main__":
    main()
