/*
 * start.S - reset entry of the firmware on bowden_soc's picorv32.
 *
 * The CPU has no interrupt (bowden_soc.v: the UP5K has no room for picorv32's IRQ logic); the
 * firmware's tick is the timer's tick count, which main.c polls.
 *
 * Reset: stack pointer, .data copied from the image, .bss cleared, the RAM between .bss and the
 * stack painted with a pattern (the simulation reads the stack's high-water mark from it), main.
 */
    .section .text.start, "ax"
    .globl _start
_start:
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
