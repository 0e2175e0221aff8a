"""Benchmark: what writing each mesh asset once (``Mesh.placements``) saves the formats that
write mesh files (MJCF, URDF, object.json) for some description files: the mesh files and
faces each part's merged meshes would need against those the export writes
(``meshfiles.MeshLayout``), the placements and distinct assets the readers found, the
assets placed more than once, the faces if each asset were written once, and whether every
visual placement lies inside one colour run (then a geom per placement carries one
colour).

    PYTHONPATH=$PWD .venv/bin/python bench/placements.py FILE...
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from real2code_export.formats import load
from real2code_export.meshfiles import MeshLayout, collision_file_meshes, visual_color_files


def survey(path: Path) -> dict:
    start = time.process_time()
    obj = load(path)
    seconds = time.process_time() - start
    files = several_colours = faces_now = inside = crossing = unplaced = 0
    uses: dict[int, list] = {}  # id(asset) -> [asset, times placed]
    for part in obj.parts:
        colour_files = visual_color_files(part)
        files += len(colour_files) + len(collision_file_meshes(part))
        several_colours += len(colour_files) > 1
        meshes = [] if part.visual is None else [part.visual]
        meshes += [m for m in part.collision if m.primitive is None]
        for mesh in meshes:
            faces_now += len(mesh.faces)
            for p in mesh.placements:
                uses.setdefault(id(p.asset), [p.asset, 0])[1] += 1
        own = None if part.visual is None else part.visual.remainder()
        if own is None:
            continue
        runs = own.face_color_runs() if own.colors else [(0, len(own.faces), None)]
        for p in own.placements:
            if any(s <= p.face and p.face_end <= e for s, e, _ in runs):
                inside += 1
            else:
                crossing += 1
        unplaced += len(own.faces) - sum(len(p.asset.faces) for p in own.placements)
    written = MeshLayout(obj).files()
    return {"file": path.name, "read_s": round(seconds, 2), "parts": len(obj.parts),
            "mesh_files_merged": files, "mesh_files_written": len(written),
            "faces_in_files_written": sum(len(m.faces) for m, _ in written.values()), "visuals_of_several_colours": several_colours,
            "placements": sum(n for _, n in uses.values()), "assets": len(uses),
            "assets_placed_more_than_once": sum(n > 1 for _, n in uses.values()),
            "faces_in_merged_files": faces_now,
            "faces_each_asset_once": sum(len(a.faces) for a, _ in uses.values()),
            "visual_placements_in_one_colour_run": inside,
            "visual_placements_across_colours": crossing, "visual_faces_in_no_placement": unplaced}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", type=Path)
    for path in parser.parse_args().files:
        print(survey(path))


if __name__ == "__main__":
    main()
