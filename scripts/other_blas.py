"""Print the environment that runs the tests on another BLAS kernel of this CPU: `OPENBLAS_CORETYPE=<kernel>`.

The suite's second pass (scripts/test.sh) uses it so that a test which holds only for one machine's floating point
(the order a kernel sums in, its use of fused multiply-add) fails here rather than on a user's machine. A kernel of
an older generation runs on every newer CPU of its family; an empty line means no other kernel can be chosen (not
OpenBLAS, or its oldest kernel already), and the second pass then differs from the first in its thread count only.
"""

from __future__ import annotations

import numpy as np
import threadpoolctl

# Older kernels each CPU generation can also run, nearest first (OpenBLAS's names, as OPENBLAS_CORETYPE takes them).
FALLBACKS = {
    "skylakex": ["Haswell", "Sandybridge"], "cooperlake": ["Haswell", "Sandybridge"],
    "sapphirerapids": ["Haswell", "Sandybridge"], "zen": ["Sandybridge", "Nehalem"],
    "haswell": ["Sandybridge", "Nehalem"], "sandybridge": ["Nehalem", "Prescott"], "nehalem": ["Prescott"],
    "neoversen1": ["ARMV8"], "neoversen2": ["NEOVERSEN1", "ARMV8"], "neoversev1": ["NEOVERSEN1", "ARMV8"],
    "cortexa72": ["ARMV8"], "cortexa57": ["ARMV8"], "armv8sve": ["ARMV8"],
}


def native_kernel() -> str | None:
    """The kernel OpenBLAS chose for this CPU, or None where numpy's BLAS is not OpenBLAS."""
    np.dot(np.ones((2, 2)), np.ones((2, 2)))
    for lib in threadpoolctl.threadpool_info():
        if lib.get("internal_api") == "openblas":
            return lib.get("architecture")
    return None


def main() -> None:
    native = native_kernel()
    choices = FALLBACKS.get((native or "").lower(), [])
    print(f"OPENBLAS_CORETYPE={choices[0]}" if choices else "")


if __name__ == "__main__":
    main()
