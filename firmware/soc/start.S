/*
 * start.S - reset and interrupt entry of the firmware on bowden_soc's picorv32.
 *
 * picorv32 (its README, "Custom Instructions for IRQ Handling") jumps to PROGADDR_IRQ (0x10) on an
 * interrupt; built with ENABLE_IRQ_QREGS = 0 it leaves the return address in x3 (gp) and the
 * pending lines in x4 (tp), so the C code must not use gp or tp (clang allocates neither, and the
 * linker's gp relaxation is off by default). `retirq` returns, `maskirq` sets the mask; both are
 * custom-0 R-type words (opcode 0001011, funct7 2 and 3) written out below.
 *
 * Reset: stack pointer, .data copied from the image, .bss cleared, the RAM between .bss and the
 * stack painted with a pattern (the simulation reads the stack's high-water mark from it), main.
 */
    .section .text.start, "ax"
    .globl _start
_start:
    j reset

    .balign 16
irq_entry:
    /* The only interrupt is the timer's: count it and acknowledge it. */
    addi sp, sp, -16
    sw t0, 0(sp)
    sw t1, 4(sp)
    lui t0, %hi(soc_ticks_seen)
    lw t1, %lo(soc_ticks_seen)(t0)
    addi t1, t1, 1
    sw t1, %lo(soc_ticks_seen)(t0)
    lui t0, 0x30000          /* SOC_IO_BASE */
    li t1, 1
    sw t1, 0x18(t0)          /* SOC_TIMER_IRQ: acknowledge */
    lw t0, 0(sp)
    lw t1, 4(sp)
    addi sp, sp, 16
    .word 0x0400000b         /* retirq */

reset:
    la sp, _stack_top
    /* .data from its load address in the image */
    la t0, _data_load
    la t1, _data_start
    la t2, _data_end
1:  bgeu t1, t2, 2f
    lw t3, 0(t0)
    sw t3, 0(t1)
    addi t0, t0, 4
    addi t1, t1, 4
    j 1b
2:  /* .bss */
    la t1, _bss_start
    la t2, _bss_end
3:  bgeu t1, t2, 4f
    sw zero, 0(t1)
    addi t1, t1, 4
    j 3b
4:  /* stack paint: from the end of .bss to just below the current frame */
    li t3, 0x57ac57ac
    addi t2, sp, -64
5:  bgeu t1, t2, 6f
    sw t3, 0(t1)
    addi t1, t1, 4
    j 5b
6:  call main
7:  j 7b

/* Unmask the timer's interrupt line (SOC_IRQ_TIMER = 3): maskirq x0, a0 with a0 = ~(1 << 3). */
    .section .text.soc_irq_enable, "ax"
    .globl soc_irq_enable
soc_irq_enable:
    li a0, ~(1 << 3)
    .word 0x0605600b         /* maskirq zero, a0 */
    ret
