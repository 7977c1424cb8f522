"""Draws docs/example/main-job.png from the output of the main job: the planned trajectory
beside the SAR image of one aperture.

    python3 docs/example/main-job.py OUT_DIR [--aperture 0] [--pixel-m 0.4] [--out docs/example/main-job.png]

OUT_DIR is the output directory of `cellsar run` (the README's main job) or of
`cellsar-radar-sim closed-loop` on the same inputs. Needs NumPy and matplotlib
(`pip install numpy matplotlib`).
"""

import argparse
import csv
import math
import pathlib
import tomllib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

# the mission-file defaults this figure needs (docs/user-guide.md, "[params]")
DEFAULT_BS_M = (1000.0, -1000.0)
DEFAULT_START_M = (-1000.0, -500.0)
DEFAULT_RADIUS_M = 200.0
DEFAULT_SLOT_S = 0.5


def floats(row, *names):
    return [float(row[n]) for n in names]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir", type=pathlib.Path)
    ap.add_argument("--aperture", type=int, default=0)
    ap.add_argument("--pixel-m", type=float, default=0.4, help="the scene's processing.pixel_m")
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("docs/example/main-job.png"))
    args = ap.parse_args()

    d = args.out_dir
    processed = d / "processed" if (d / "processed" / "images").is_dir() else d
    params = tomllib.loads((d / "plan" / "mission.toml").read_text()).get("params", {})
    bs = params.get("bs_m", DEFAULT_BS_M)
    start = params.get("start_m", DEFAULT_START_M)
    radius = params.get("sensing_radius_m", DEFAULT_RADIUS_M)
    slot_s = params.get("slot_s", DEFAULT_SLOT_S)

    rows = list(csv.DictReader(open(d / "plan" / "trajectory.csv")))[1:]
    pos = np.array([floats(r, "x_m", "y_m") for r in rows])
    centre = np.array([floats(r, "xc_m", "yc_m") for r in rows])
    landmarks = []
    for r in rows:
        if r["landmark_x_m"] != "nan":
            p = tuple(floats(r, "landmark_x_m", "landmark_y_m"))
            if not landmarks or landmarks[-1] != p:
                landmarks.append(p)
    landmarks = np.array(landmarks)
    energy = float(rows[-1]["energy_j"])

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 5.4), gridspec_kw={"width_ratios": [1.15, 1]})

    # left: the plan
    ax1.plot(pos[:, 0], pos[:, 1], color="tab:blue", lw=1.6, label="UAV track (1000 m altitude)")
    ax1.plot(centre[:, 0], centre[:, 1], color="tab:orange", lw=1.0, ls="--",
             label="sensing centre (1000 m to the right)")
    ax1.scatter(landmarks[:, 0], landmarks[:, 1], s=9, color="black", zorder=3, label="landmarks")
    ax1.plot(*start, marker="o", color="tab:blue", ms=6, ls="none")
    ax1.plot(*bs, marker="^", color="tab:green", ms=10, ls="none", label="base station")
    n = len(rows)
    for k in range(0, n, n // 6):
        t = k + 1
        c = centre[k]
        ax1.add_patch(plt.Circle(c, radius, fill=False, color="tab:orange", lw=0.7, alpha=0.6))
        ax1.plot([pos[k, 0], c[0]], [pos[k, 1], c[1]], color="grey", lw=0.5, alpha=0.6)
        label = f"{t * slot_s:.0f} s" if k else "start"
        ax1.annotate(label, pos[k], textcoords="offset points", xytext=(4, 4),
                     fontsize=8, color="tab:blue")
    lx, ly = landmarks[args.aperture]
    img = np.load(processed / "images" / f"aperture_{args.aperture:03d}.npy")
    ny, nx = img.shape
    half_x, half_y = (nx - 1) / 2 * args.pixel_m, (ny - 1) / 2 * args.pixel_m
    ax1.add_patch(plt.Rectangle((lx - half_x, ly - half_y), 2 * half_x, 2 * half_y, fill=False,
                                color="tab:red", lw=1.2, label=f"image of aperture {args.aperture}"))
    ax1.set_aspect("equal")
    ax1.set_xlabel("x (m, east)")
    ax1.set_ylabel("y (m, north)")
    ax1.set_title(f"planned trajectory: {energy:,.0f} J in {n * slot_s:.0f} s".replace(",", " "))
    ax1.legend(loc="lower left", fontsize=8)
    ax1.grid(alpha=0.3)

    # right: the SAR image of one aperture
    db = 10 * np.log10(np.maximum(img, 1e-12))
    top = math.ceil(db.max())
    im = ax2.imshow(db, origin="lower", cmap="viridis", vmin=top - 40, vmax=top,
                    extent=(lx - half_x, lx + half_x, ly - half_y, ly + half_y))
    fig.colorbar(im, ax=ax2, label="dB over noise", fraction=0.046, pad=0.04)
    dets = [r for r in csv.DictReader(open(processed / "detections.csv"))
            if int(r["aperture"]) == args.aperture]
    for r in dets:
        x, y = floats(r, "x_m", "y_m")
        colour = "white" if r["truth_id"] else "red"
        ax2.plot(x, y, marker="o", ms=11, mfc="none", mec=colour, mew=1.2)
    ax2.plot([], [], marker="o", ms=9, mfc="none", mec="white", ls="none", label="detection")
    ax2.legend(loc="upper right", fontsize=8, facecolor="grey", framealpha=0.5)
    ax2.set_xlabel("x (m, east)")
    ax2.set_ylabel("y (m, north)")
    ax2.set_title(f"SAR image of aperture {args.aperture} (landmark at {lx:.0f}, {ly:.0f} m)")

    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=100)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
