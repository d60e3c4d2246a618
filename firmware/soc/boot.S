/*
 * boot.S - the UP5K's boot loader: copies the image from the SPI flash into the program memory,
 * then jumps to it. It sits in a small block RAM that the bitstream initialises (bowden_soc.v
 * BOOT_INIT, at SOC_BOOT_BASE, where the CPU starts): the UP5K's SPRAMs, which hold the image,
 * cannot be initialised by the bitstream.
 *
 * Flash layout at 0x080000 (firmware/soc/tools/mkimage.py --flash): a 32-bit little-endian byte
 * count, then the image. Release from power-down (0xAB) and wait tRES1 (3 us, W25Q128JV sec. 9.6),
 * then one read (0x03) of the count and the image's bytes. A count of 0 or above the program
 * memory (a blank flash reads 0xFFFFFFFF) is no image: the loader stops there, the CPU never
 * reaches the image (bowden_soc's boot_done stays low, the board's red LED on).
 * The copy goes a byte at a time with the next byte's transfer started before this one is
 * stored, so the SPI's 16 clocks a byte overlap the loop's instructions: 28 clocks a byte
 * (tests/soc/test_soc_flash_boot.py, which holds the boot's budget, tests/soc/soc_sim.py
 * BOOT_MAX_CLKS, for an image filling the program memory). A call to xfer a byte and a word
 * assembled by shifts took 62, 3 275 000 clocks for the 52 596-byte image: past that budget.
 * Registers: s0 the I/O base, s1 the image's end, s2 the destination, a1 the count, t6 the busy
 * bit, ra / t5 the two return addresses.
 */
    .section .text.boot, "ax"
    .globl _boot
_boot:
    li s0, 0x30000000            /* SOC_IO_BASE */
    li t0, 1
    sw t0, 0x20(s0)              /* SOC_SPI_CS: select */
    li a0, 0xAB                  /* release from power-down */
    jal ra, xfer
    sw zero, 0x20(s0)
    li t0, 32                    /* tRES1: 32 loops of two instructions, over 200 clocks */
1:  addi t0, t0, -1
    bnez t0, 1b
    li t0, 1
    sw t0, 0x20(s0)
    li a0, 0x03                  /* read from 0x080000 */
    jal ra, xfer
    li a0, 0x08
    jal ra, xfer
    li a0, 0x00
    jal ra, xfer
    li a0, 0x00
    jal ra, xfer
    jal t5, word                 /* the byte count */
    beqz a1, no_image
    li t1, 0x10000               /* the program memory: 64 KiB (SOC_ROM_BYTES) */
    bgtu a1, t1, no_image
    mv s1, a1                    /* the end: SOC_ROM_BASE (0) + the count */
    li s2, 0                     /* SOC_ROM_BASE */
    li t6, 0x100                 /* SOC_SPI_DATA's busy bit: a read at or above it is busy */
    sw zero, 0x24(s0)            /* the first byte's transfer */
2:  lw a0, 0x24(s0)
    bgeu a0, t6, 2b
    sw zero, 0x24(s0)            /* the next byte shifts in while this one is stored */
    sb a0, 0(s2)
    addi s2, s2, 1
    bne s2, s1, 2b
5:  lw a0, 0x24(s0)              /* the transfer one byte past the image ends */
    bgeu a0, t6, 5b
    sw zero, 0x20(s0)
    jr zero                      /* the image's _start */
no_image:
    sw zero, 0x20(s0)
3:  j 3b

/* a1 = the next four bytes, little-endian (returns through t5) */
word:
    li a0, 0
    jal ra, xfer
    mv a1, a0
    li a0, 0
    jal ra, xfer
    slli a0, a0, 8
    or a1, a1, a0
    li a0, 0
    jal ra, xfer
    slli a0, a0, 16
    or a1, a1, a0
    li a0, 0
    jal ra, xfer
    slli a0, a0, 24
    or a1, a1, a0
    jr t5

/* send a0, a0 = the byte received (SOC_SPI_DATA: bit 8 busy) */
xfer:
    sw a0, 0x24(s0)
4:  lw a0, 0x24(s0)
    andi t0, a0, 0x100
    bnez t0, 4b
    andi a0, a0, 0xFF
    ret
