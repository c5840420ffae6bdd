"""The gallery of the documentation site: run every demo and keep its pictures.

Runs each demo of ``demos/`` serially, as a user would (``python demos/X.py --out OUT
--quiet`` and the flags of :data:`FLAGS`), copies the PNG files it drew into
``docs/gallery/X/`` (re-saved smaller when larger than :data:`LARGEST_PNG`) and records
the run in ``docs/gallery/gallery.json``: the command, its wall time, the commit, the
package version, the demo file's SHA-256 and the pictures with their captions. With
demo names (file stems), only those run and the manifest keeps the others' entries::

    make gallery                          # every demo
    make gallery DEMOS="ring_2d bar_1d"   # only these, merged into the manifest

A demo that fails is named on one line after the others have run, and the exit status
is 1; its entry and pictures stay as they were.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import os
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEMOS = ROOT / "demos"
GALLERY = ROOT / "docs" / "gallery"
MANIFEST = GALLERY / "gallery.json"
LARGEST_PNG = 150_000  # bytes

#: Flags of each demo beyond ``--out OUT --quiet``: none where the demo's defaults finish
#: in a few minutes.
FLAGS: dict[str, list[str]] = {}

#: What each picture shows, by demo and file name.
CAPTIONS = {
    ("ball_3d", "energy.png"): "The energy of the ball's impact with the four schemes of the "
    "talk: the hybrid scheme keeps it, the others lose or gain some at the impact.",
    ("ball_3d", "deformed_t18.png"): "The ball at t = 18, flattened on the plane, coloured by "
    "its von Mises stress; right, its far half cut through the centre.",
    ("ball_on_slab_3d", "energy.png"): "The energies of the ball falling on the deformable "
    "slab, and the contact force between them.",
    ("ball_on_slab_3d", "deformed_t8.png"): "The ball pressing into the slab at t = 8, "
    "coloured by the von Mises stress.",
    ("bar_1d", "bar_1d.png"): "The talk's bar against its exact solution: displacement, "
    "velocity and contact stress at the contact end, and the energy, for each scheme.",
    ("bar_loop_1d", "bar_loop_1d.png"): "The bar of the time loop written out: displacement, "
    "velocity and contact stress at the contact end, and the energy.",
    ("block_on_slab_2d", "energy.png"): "The energies of the block sliding on the slab: the "
    "kinetic energy goes into the friction's work; below, the contact force at the time "
    "levels. It swings from step to step (the stiff block's stresses at the levels, not at "
    "the midpoints the steps use): the friction's work, 2.24 = mu_f N times the distance "
    "slid, gives the steps' normal force N = 1.99, the block's weight.",
    ("block_on_slab_2d", "deformed.png"): "The block at t = 8.5, stopped on the slab some 5.6 "
    "from where it started, coloured by the von Mises stress.",
    ("c_shape_2d", "energy.png"): "The energies of the C-shaped body landing on the ground, "
    "with the slot's pairings taken out of E_Theta.",
    ("c_shape_2d", "deformed_t0.46.png"): "The C-shaped body at t = 0.46, its slot closed on "
    "itself at the open end, coloured by the von Mises stress.",
    ("compare_methods_1d", "compare_methods_1d.png"): "The bar with Nitsche's method, "
    "penalty and the mixed method: contact stress and energy against the exact solution.",
    ("convergence_1d", "convergence_1d.png"): "The errors of the bar against its exact "
    "solution as the mesh and the step are refined, with their orders.",
    ("disk_2d", "energy.png"): "The energy of the disk's impact with the four schemes of the talk.",
    ("disk_2d", "deformed_t18.png"): "The disk at t = 18, flattened on the line, coloured by "
    "its von Mises stress.",
    ("friction_block_2d", "energy.png"): "The energies of the block sliding on the rigid "
    "plane until friction stops it, and the contact force.",
    ("friction_block_2d", "deformed.png"): "The block at t = 7, stuck on the plane since "
    "friction stopped it, coloured by the von Mises stress (its deformation too small to "
    "see).",
    ("indenter_2d", "energy.png"): "Where the indenter's work goes: the energies, the energy "
    "balance and the forces of the indenter and the ground.",
    ("indenter_2d", "deformed.png"): "The steel slab under the indenter at the end of the "
    "run, coloured by the von Mises stress.",
    ("ring_2d", "ring_2d.png"): "The energies of the bouncing ring and its contact force.",
    ("ring_2d", "deformed_t0.3.png"): "The ring at t = 0.3, flattened on the ground, coloured "
    "by the von Mises stress.",
    ("rubber_ball_3d", "energy.png"): "The energies of the neo-Hookean ball's impact and its "
    "contact force.",
    ("rubber_ball_3d", "deformed.png"): "The rubber ball at t = 2.4, flattened on the ground, "
    "coloured by the von Mises stress.",
    ("shaker_2d", "energy.png"): "Where the shaker's work goes: the energies, the energy "
    "balance and the contact force.",
    ("shaker_2d", "deformed.png"): "The body on the shaker, coloured by the von Mises stress.",
    ("sliding_disks_2d", "energy.png"): "The energies of the two disks sliding past each other, "
    "with the pairings' change taken out of E_Theta.",
    ("sliding_disks_2d", "deformed_t9.png"): "The two disks at t = 9, in the middle of their "
    "sliding, coloured by the von Mises stress.",
    ("soft_ring_2d", "energy.png"): "The energies of the soft ring hitting the wall and its "
    "contact force.",
    ("soft_ring_2d", "deformed_t1.4.png"): "The soft ring at t = 1.4, flattened on the wall to "
    "its left, coloured by the von Mises stress.",
    ("two_balls_3d", "energy.png"): "The energies of the two balls colliding head-on and their "
    "contact force.",
    ("two_balls_3d", "deformed_t8.png"): "The two balls pressed against each other at t = 8, "
    "coloured by the von Mises stress.",
    ("two_bars_1d", "two_bars_1d.png"): "The two bars colliding against the exact solution.",
    ("two_bars_1d", "energy.png"): "The energies of the two bars and their contact force.",
    ("two_bars_1d", "worldlines.png"): "The two bars where they are against time, coloured "
    "by their velocity: they meet, push each other back and fly apart.",
    ("two_disks_2d", "energy.png"): "The energies of the two disks colliding head-on and their "
    "contact force.",
    ("two_disks_2d", "deformed_t8.png"): "The two disks pressed against each other at t = 8, "
    "coloured by the von Mises stress.",
}


def caption(demo: str, file: str) -> str:
    """The caption of a picture: from :data:`CAPTIONS`, or one naming the demo."""
    return CAPTIONS.get((demo, file), f"A picture drawn by demos/{demo}.py ({file}).")


def command(demo: str) -> list[str]:
    """The demo's command line, OUT standing for its output folder."""
    return ["python", f"demos/{demo}.py", "--out", "OUT", "--quiet", *FLAGS.get(demo, [])]


def run_demo(demo: str, out: Path) -> tuple[float, int]:
    """Run ``demo`` into ``out`` with this tree's package; its wall time and exit status
    (its output in ``out.log``)."""
    if out.exists():
        shutil.rmtree(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    argv = [sys.executable, *command(demo)[1:]]
    argv[argv.index("OUT")] = str(out)
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    start = time.perf_counter()
    with open(f"{out}.log", "w") as log:
        status = subprocess.run(argv, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)
    return time.perf_counter() - start, status.returncode


def save_png(source: Path, target: Path) -> None:
    """Copy a PNG, re-saved smaller if it is larger than :data:`LARGEST_PNG`: first in 256
    colours (dithered, so that the colour bars and shaded bodies show no bands), then scaled
    down by steps of 0.8."""
    if source.stat().st_size <= LARGEST_PNG:
        shutil.copyfile(source, target)
        return
    from PIL import Image

    image = Image.open(source).convert("RGB")
    scale = 1.0
    while True:
        size = (round(image.width * scale), round(image.height * scale))
        smaller = image.resize(size, Image.LANCZOS) if scale < 1.0 else image
        palette = smaller.quantize(256, method=Image.Quantize.FASTOCTREE)
        smaller = smaller.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG)
        data = io.BytesIO()
        smaller.save(data, format="PNG", optimize=True)
        if data.tell() <= LARGEST_PNG or scale < 0.3:
            target.write_bytes(data.getvalue())
            return
        scale *= 0.8


def git_commit() -> str:
    result = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
    )
    return result.stdout.strip() or "unknown"


def package_version() -> str:
    text = (ROOT / "nitsche_dolfinx" / "__init__.py").read_text()
    line = next(line for line in text.splitlines() if line.startswith("__version__"))
    return line.split("=", 1)[1].strip().strip("\"'")


def entry(demo: str, seconds: float, pictures: list[str]) -> dict:
    """The manifest's entry of a demo run."""
    return {
        "command": shlex.join(command(demo)),
        "seconds": round(seconds, 1),
        "commit": git_commit(),
        "version": package_version(),
        "demo_sha256": hashlib.sha256((DEMOS / f"{demo}.py").read_bytes()).hexdigest(),
        "pictures": [
            {"file": f"{demo}/{file}", "caption": caption(demo, file)} for file in pictures
        ],
    }


def keep_pictures(demo: str, out: Path) -> list[str]:
    """Replace the demo's gallery folder by the PNG files of ``out``; their names."""
    folder = GALLERY / demo
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    names = sorted(path.name for path in out.glob("*.png"))
    for name in names:
        save_png(out / name, folder / name)
    return names


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    every = sorted(path.stem for path in DEMOS.glob("*.py"))
    parser.add_argument("demos", nargs="*", help=f"file stems of demos (default: all {len(every)})")
    parser.add_argument("--work", default="out/gallery", help="the demos' output folders")
    args = parser.parse_args(argv)
    unknown = sorted(set(args.demos) - set(every))
    if unknown:
        parser.error(f"no such demo: {', '.join(unknown)} (demos: {', '.join(every)})")
    manifest = json.loads(MANIFEST.read_text()) if MANIFEST.exists() else {"demos": {}}
    failed = []
    for demo in args.demos or every:
        out = Path(args.work).resolve() / demo
        print(f"gallery: {shlex.join(command(demo))}", flush=True)
        seconds, status = run_demo(demo, out)
        if status != 0:
            failed.append(f"gallery: demos/{demo}.py failed (exit status {status}; {out}.log)")
            print(failed[-1], flush=True)
            continue
        pictures = keep_pictures(demo, out)
        if not pictures:
            failed.append(f"gallery: demos/{demo}.py drew no picture ({out}.log)")
        manifest["demos"][demo] = entry(demo, seconds, pictures)
        names = ", ".join(pictures) or "no picture"
        print(f"gallery: {demo} in {seconds:.1f} s: {names}", flush=True)
        GALLERY.mkdir(parents=True, exist_ok=True)
        manifest["demos"] = dict(sorted(manifest["demos"].items()))
        MANIFEST.write_text(json.dumps(manifest, indent=2) + "\n")
    for line in failed:
        print(line, file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
