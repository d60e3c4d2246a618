"""The firmware's image in the forms the SoC loads (make firmware-soc).

    python firmware/soc/tools/mkimage.py IMAGE.bin --rom-bytes N --hex OUT.hex --flash OUT.bin

--hex: one 32-bit little-endian word per line, the ROM's $readmemh file, padded with zeros to
the ROM's size (hdl/soc/bowden_soc.v, ROM_WORDS). --flash: the image as the UP5K's boot copier reads
it from the SPI flash: a 32-bit little-endian byte count, then the image (hdl/soc/soc_boot.v).
Exit 2 with one line when the image does not fit the ROM.
"""

from __future__ import annotations

import argparse
import struct
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("image", type=Path)
    ap.add_argument("--rom-bytes", type=int, required=True)
    ap.add_argument("--hex", type=Path, required=True)
    ap.add_argument("--flash", type=Path, required=True)
    args = ap.parse_args(argv)
    data = args.image.read_bytes()
    data += b"\0" * (-len(data) % 4)
    if len(data) > args.rom_bytes:
        print(
            f"mkimage: {args.image}: {len(data)} bytes do not fit the ROM's {args.rom_bytes}",
            file=sys.stderr,
        )
        return 2
    words = struct.unpack(f"<{len(data) // 4}I", data)
    words += (0,) * (args.rom_bytes // 4 - len(words))
    for out, payload in (
        (args.hex, "".join(f"{w:08x}\n" for w in words).encode()),
        (args.flash, struct.pack("<I", len(data)) + data),
    ):
        tmp = out.with_suffix(out.suffix + ".tmp")
        tmp.write_bytes(payload)
        tmp.replace(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
