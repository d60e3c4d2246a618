"""The firmware's image in the forms the SoC loads (make firmware-soc).

    python -m firmware.soc.tools.mkimage IMAGE.bin --rom-bytes N --hex OUT.hex [--flash OUT.bin]

--hex: one 32-bit little-endian word per line, the ROM's $readmemh file, padded with zeros to
the ROM's size (hdl/soc/bowden_soc.v, ROM_WORDS). --flash: the image as the UP5K's boot loader reads
it from the SPI flash: a 32-bit little-endian byte count, then the image (firmware/soc/boot.S).
--flash-hex: the same bytes as the flash simulation model's $readmemh file, placed at
--flash-addr (default 0x080000, the UP5K's boot address).
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
    ap.add_argument("--flash", type=Path, default=None)
    ap.add_argument("--flash-hex", type=Path, default=None)
    ap.add_argument("--flash-addr", type=lambda v: int(v, 0), default=0x080000)
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
    flash = struct.pack("<I", len(data)) + data
    outputs = [(args.hex, "".join(f"{w:08x}\n" for w in words).encode())]
    if args.flash is not None:
        outputs.append((args.flash, flash))
    if args.flash_hex is not None:
        text = f"@{args.flash_addr:06x}\n" + "".join(f"{b:02x}\n" for b in flash)
        outputs.append((args.flash_hex, text.encode()))
    for out, payload in outputs:
        tmp = out.with_suffix(out.suffix + ".tmp")
        tmp.write_bytes(payload)
        tmp.replace(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
