"""Write tests/fmu/geometry_vectors.json, the shared test vectors of the bending-angle geometry.

    .venv/bin/python tests/fmu/gen_geometry_vectors.py

Closed-form cases carry the value the derivation in fmu/README.md gives (independent of both
implementations); the other positions are drawn at random in the half-sphere and carry the
value of cosim/parts/geometry.py at the time of writing, so that the C geometry in the FMU and the
Python twin are held to the same numbers.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from cosim.parts.geometry import bending_angle

TWO_PI = 2 * math.pi

CLOSED_FORM = [
    # (x, y, z, L, loop_routing, phi, why)
    (0.0, 1.0, 0.0, 1.0, False, 0.0, "straight sheath along the outlet axis"),
    (0.0, 2.0, 0.0, 2.0, False, 0.0, "straight sheath, L = 2 m"),
    (0.0, 0.0, 0.0, 1.0, False, TWO_PI, "C at A: down, U-turn, up (pi/2 + pi + pi/2)"),
    (0.0, 0.0, -1.0, 1.0, False, math.pi, "straight down: pi/2 at A, pi/2 at C"),
    (1.0, 0.0, 0.0, 1.0, False, math.pi, "straight along x: pi/2 at each end"),
    (0.0, 0.6, -0.2, 1.0, True, TWO_PI, "loop, in the loop's plane x = 0"),
    (0.0, 0.2, 0.5, 1.0, True, TWO_PI, "loop, in plane, above the outlet"),
    (0.0, 0.9, -0.3, 1.0, True, TWO_PI, "loop, in plane, far"),
    (0.0, 0.05, -0.7, 1.0, True, TWO_PI, "loop, in plane, low"),
    (0.0, 0.3, 0.1, 0.5, True, TWO_PI, "loop, in plane, L = 0.5 m"),
]


def main() -> None:
    rng = np.random.default_rng(2015)
    vectors = [
        {"x": x, "y": y, "z": z, "L": L, "loop_routing": loop, "phi_rad": phi, "closed_form": why}
        for x, y, z, L, loop, phi, why in CLOSED_FORM
    ]
    count = 0
    while count < 48:
        L = float(rng.choice([1.0, 0.7, 1.5]))
        x, y, z = (float(v) for v in rng.uniform([-L, 0, -L], [L, L, L]))
        if x * x + y * y + z * z > L * L:
            continue
        loop = bool(count % 2)
        phi = bending_angle(x, y, z, L, loop)
        vectors.append({"x": x, "y": y, "z": z, "L": L, "loop_routing": loop, "phi_rad": phi})
        count += 1
    path = Path(__file__).with_name("geometry_vectors.json")
    path.write_text(json.dumps(vectors, indent=1) + "\n")
    print(f"wrote {len(vectors)} vectors to {path}")


if __name__ == "__main__":
    main()
