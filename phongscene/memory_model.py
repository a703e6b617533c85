# SPDX-License-Identifier: Apache-2.0
"""What reading a scene needs in memory, announced by the reader before it allocates it.

The sandboxed reader (``phongscene.sandbox``) caps its child's address space, and a constant cap
either refuses ordinary scenes (one 4096² texture) or lets a corrupt file take the machine. So the
cap follows a model of the scene, built while it is read: the interpreter's measured base, then,
announced before each is read, ``MEMORY_PER_FILE_BYTE`` per byte of each layer file and the decoded
size of each texture from its header. A corrupt file still meets a limit sized by what it claims
to be on disk, and a texture by the texels its header declares (bounded by ``limits``).

``announce`` does nothing unless a listener is installed (only the sandbox's child installs one).
This module imports nothing heavy: the CLI and the sandbox's parent import it.
"""

from __future__ import annotations

from collections.abc import Callable

# Address space per byte of a layer file: a crate file's compressed arrays expand, USD keeps them,
# the model copies them as float64 / int32 and the sandbox pickles the model (measured by
# benchmarks/sandbox.py: a 1M-triangle .usdc of 17 MiB peaks at ~0.5 GiB resident).
MEMORY_PER_FILE_BYTE = 64
# The model's texels: float32 RGB.
MODEL_BYTES_PER_TEXEL = 12
# One block of ``texture_files.texels``'s conversion (2^18 texels): its float32 / float64 temporaries
# and OpenImageIO's sRGB buffers, ~130 bytes a texel, with room to spare.
TEXTURE_BLOCK_BYTES = 64 << 20

_listener: Callable[[int, str], None] | None = None


def texture_decode_bytes(texels: int, channels: int, bytes_per_channel: int) -> int:
    """Bytes of a texture file's pixels decoded in their stored precision."""
    # OpenImageIO decodes into a buffer of its own, then copies it into the returned array
    # (measured: a 64 MB 8192² grey PNG peaks at 128 MB more).
    return 2 * texels * channels * bytes_per_channel


def texture_model_bytes(texels: int) -> int:
    """Bytes of one model texture built from decoded pixels (the float32 RGB image and the
    temporaries of building it a block at a time)."""
    return texels * MODEL_BYTES_PER_TEXEL + TEXTURE_BLOCK_BYTES


def layer_bytes(file_size: int) -> int:
    """Bytes reading a layer file of ``file_size`` bytes may take, all told."""
    return MEMORY_PER_FILE_BYTE * file_size


def announce(nbytes: int, what: str) -> None:
    """Say that reading ``what`` is about to need ``nbytes`` more bytes."""
    if _listener is not None:
        _listener(int(nbytes), what)


def listen(listener: Callable[[int, str], None] | None) -> None:
    """Install ``listener(nbytes, what)`` for every ``announce`` (None removes it)."""
    global _listener
    _listener = listener
