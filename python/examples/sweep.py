"""Plans the default mission at landmark spacings of 30-200 m and plots the true energy of each
plan against its spacing (with the energy floor T * P(V*) for reference).

    pip install ./python matplotlib
    python python/examples/sweep.py --out sweep.png
"""

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import cellsar  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="sweep.png", help="the figure (PNG)")
    parser.add_argument("--count", type=int, default=18, help="number of spacings")
    args = parser.parse_args()

    spacings = np.linspace(30.0, 200.0, args.count)
    energies, floors = [], []
    for spacing in spacings:
        plan = cellsar.plan(cellsar.Mission.default(spacing_m=float(spacing)))
        summary = plan.summary
        energies.append(summary["energy_j"])
        floors.append(summary["floor_energy_j"])
        print(f"{spacing:6.1f} m: {summary['energy_j']:9.1f} J, feasible {summary['feasible']}")

    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(spacings, np.array(energies) / 1e3, "o-", label="exact scheme")
    ax.plot(spacings, np.array(floors) / 1e3, "--", label="floor T·P(V*)")
    ax.set_xlabel("landmark spacing (m)")
    ax.set_ylabel("true propulsion energy (kJ)")
    ax.set_title("Default mission: energy against spacing")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
