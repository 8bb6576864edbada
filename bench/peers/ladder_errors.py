"""Errors of one renderer's spp ladder against its own two-half reference, with numpy alone (it
runs where moonbot is not installed, e.g. beside Mitsuba's CUDA variant on a GPU machine).

Reads DIR/timings.json and DIR/rgb_sppN.npy (mitsuba_render.py's outputs) and the reference's two
halves DIR/<a>rgb_sppM.npy, DIR/<b>rgb_sppM.npy (the same script run with --prefix and distinct
seeds). The error of an image is compare.py's: the relative RMSE of linear radiance against the
halves' mean, the reference's own noise var_ref = mean((h1 − h2)²)/4 subtracted from the squared
error. Prints JSON: the ladder's rows with their errors, and the spp and seconds a frame at each
target error (log-log interpolation between the bracketing rows, as compare.py's at_error).

  python3 bench/peers/ladder_errors.py DIR --reference refa_,refb_ --reference-spp 4096
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np


def rel_errors(img: np.ndarray, ref: np.ndarray, var_ref: float) -> dict:
    """(compare.py's too.) Relative RMSE of `img` against `ref` (both (H, W, 3) linear radiance), noise-corrected."""
    d = img.astype(np.float64) - ref
    mse = float(np.mean(d * d))
    rms = float(np.sqrt(np.mean(ref * ref)))
    return {
        "rel_rmse": math.sqrt(max(0.0, mse - var_ref)) / rms,
        "rel_rmse_raw": math.sqrt(mse) / rms,
        "mean_ratio": float(img.mean() / ref.mean()),
    }


def at_error(rows: list[dict], target: float) -> dict | None:
    """spp, seconds a frame and seconds a sample at `target` relative RMSE, interpolated log-log between the first
    pair of rows that brackets it; None where the ladder does not reach it."""
    for a, b in zip(rows, rows[1:]):
        ea, eb = a["rel_rmse"], b["rel_rmse"]
        if ea >= target >= eb and ea > 0 and eb > 0 and ea != eb:
            f = math.log(ea / target) / math.log(ea / eb)
            spp = math.exp(math.log(a["spp"]) + f * math.log(b["spp"] / a["spp"]))
            seconds = math.exp(math.log(a["render_s"]) + f * math.log(b["render_s"] / a["render_s"]))
            return {"spp": spp, "seconds_per_frame": seconds, "seconds_per_sample": seconds / spp}
    return None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dir", type=Path)
    parser.add_argument("--reference", default="refa_,refb_", help="the two halves' file prefixes")
    parser.add_argument("--reference-spp", type=int, required=True)
    parser.add_argument("--targets", default="0.1,0.05,0.03,0.02,0.01")
    args = parser.parse_args()

    a, b = args.reference.split(",")
    h1 = np.load(args.dir / f"{a}rgb_spp{args.reference_spp}.npy").astype(np.float64)
    h2 = np.load(args.dir / f"{b}rgb_spp{args.reference_spp}.npy").astype(np.float64)
    ref = 0.5 * (h1 + h2)
    var_ref = float(np.mean((h1 - h2) ** 2)) / 4.0
    timings = json.loads((args.dir / "timings.json").read_text())
    rows = []
    for row in timings["rows"]:
        img = np.load(args.dir / f"rgb_spp{row['spp']}.npy")
        rows.append({**row, **rel_errors(img, ref, var_ref)})
    out = {
        **{k: v for k, v in timings.items() if k != "rows"},
        "rows": rows,
        "reference": {
            "spp_per_half": args.reference_spp,
            "own_rel_rmse": math.sqrt(var_ref) / float(np.sqrt(np.mean(ref * ref))),
        },
        "at_error": {t: at_error(rows, float(t)) for t in args.targets.split(",")},
    }
    json.dump(out, sys.stdout, indent=2)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
