"""The array type aliases of the project (for annotations; NumPy's ``NDArray`` of one dtype).

Shapes, frames and units are in each function's docstring; these name only the dtype.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["BoolArray", "Float32Array", "FloatArray", "Int8Array", "IntArray", "UInt8Image"]

FloatArray = NDArray[np.float64]
"""float64 arrays: coordinates (metres, pixels), covariances, probabilities."""
Float32Array = NDArray[np.float32]
"""float32 arrays: observation features."""
IntArray = NDArray[np.int64]
"""int64 arrays: indices, counts, labels."""
Int8Array = NDArray[np.int8]
"""int8 arrays: small codes (signs, relation tags)."""
BoolArray = NDArray[np.bool_]
"""bool arrays: masks."""
UInt8Image = NDArray[np.uint8]
"""uint8 images: (H, W) grey or (H, W, 3) RGB, and rasters."""
