"""The microprogram of tension_loop_seq: its instruction set, an assembler, an instruction-level
simulator of the engine, the loop's program, and the ROM it is written into.

The engine (hdl/rtl/tension_loop_seq.v) executes one 32-bit microinstruction a clock, straight
line, each under an optional predicate (one of eight flags, either polarity): a 16-bit
accumulator ACC, one adder with carry (multi-word sums and comparisons over 16-bit words), AND,
a funnel shift of {B, ACC} right by 7, 9 or 11, a registered 16 x 16 multiplier whose
product P can be read from the third instruction after the MUL on, a scratchpad of 256 words
(64 a channel, 64 shared), and output registers written by OUT. B, the second operand, is one of:
a scratchpad word, an immediate, P's low or high half, a configuration field (phase 0 only), the
channel's events, ACC's sign as a word, or the watchdog ramp step.

Two hazards of the two-stage pipeline are resolved here, not in hardware: a scratchpad word is
read a clock before its instruction executes, so an instruction never reads the word the one
before it stores (the assembler puts a NOP between), and P is read no earlier than the third
instruction after its MUL (`mul` is followed by two NOPs).

`simulate_period` runs the program as the engine does (phase 0 then phase 1 for each channel);
tests/hdl/test_seq_program.py holds it to cosim/parts/rtl_model.py's TensionLoopMcModel, and the
RTL tests hold the engine to the same model.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROM_FILE = Path(__file__).resolve().parents[1] / "rtl" / "tension_loop_seq_rom.v"
ROM_WORDS = 512

# Ops.
NOP, LD, ADD, ADC, SUB, SBC, AND, HOLD, ST, MUL, SHR, SETF, OUT, END = range(14)
# B sources.
B_RAM, B_IMM, B_PLO, B_PHI, B_CFG, B_EV, B_SGN, B_STEP = range(8)
# SETF conditions (imm[2:0]); imm[3] inverts.
C_S, C_Z, C_C, C_LE, C_V, C_ZERO = range(6)
# Shift amounts (aux).
SHIFT = {7: 0, 9: 1, 11: 2}
SHIFT_BY = {v: k for k, v in SHIFT.items()}
# OUT fields (aux).
O_U, O_TIN, O_TCE, O_IL, O_IH, O_FAULT, O_STATUS = range(7)
# Configuration fields (the field memory's index, bowden_core_mc's cfg_index).
(
    F_TC,
    F_KFF,
    F_KP,
    F_KI,
    F_LIM,
    F_SLEW,
    F_WDT,
    F_OFF,
    F_GAIN,
    F_MIN,
    F_MAX,
    F_STALE,
    F_OC,
    F_TCMIN,
    F_UFF,
) = range(15)
CFG_NAMES = [
    "TC",
    "KFF",
    "KP",
    "KI_TS",
    "I_LIMIT",
    "SLEW",
    "WDT_TIMEOUT",
    "ADC_OFFSET",
    "ADC_GAIN",
    "ADC_MIN",
    "ADC_MAX",
    "ADC_STALE",
    "OC_TIMEOUT",
    "TC_MIN",
    "UFF",
]
# Event bits (EV source 2).
EV_ENABLE, EV_SLEW_EN, EV_FRESH, EV_TCW, EV_IRST, EV_FCLR, EV_GRP = range(7)

SHARED = 0x80  # scratchpad address bit: the shared words (else the channel's)

M16 = 0xFFFF


@dataclass
class Instr:
    op: int
    bsel: int = 0
    imm: int = 0
    aux: int = 0
    pred: tuple[int, bool] | None = None  # (flag, value it must have)

    def word(self) -> int:
        p = 0 if self.pred is None else (0x10 | (0x8 if self.pred[1] else 0) | self.pred[0])
        return (self.op << 28) | (self.bsel << 25) | (p << 20) | (self.aux << 16) | (self.imm & M16)

    def pre(self) -> int:
        """What the word before this one reads for it: its scratchpad word or its field."""
        r = self.reads_ram()
        if r is not None:
            return r
        return self.imm & 0x1F if self.bsel == B_CFG and self.op == LD else 0

    def reads_ram(self) -> int | None:
        """The scratchpad field this instruction reads, or None."""
        uses_b = self.op in (LD, ADD, ADC, SUB, SBC, AND, MUL, SHR)
        return (self.imm & 0xBF) if uses_b and self.bsel == B_RAM else None


class Asm:
    """Builds a straight-line program; `p=(flag, value)` predicates an instruction."""

    def __init__(self) -> None:
        self.code: list[Instr] = []

    def emit(self, ins: Instr) -> None:
        if self.code:
            last = self.code[-1]
            reads = ins.reads_ram()
            if last.op == ST and reads is not None and reads == (last.imm & 0xBF):
                self.code.append(Instr(NOP))
        self.code.append(ins)

    @staticmethod
    def _src(src) -> tuple[int, int]:
        if isinstance(src, int):
            return B_RAM, src
        kind = src[0]
        if kind == "imm":
            return B_IMM, src[1] & M16
        if kind == "cfg":
            return B_CFG, src[1] | (0x10 if len(src) > 2 and src[2] else 0)
        if kind == "ev":
            return B_EV, src[1]
        return {"plo": B_PLO, "phi": B_PHI, "sgn": B_SGN, "step": B_STEP}[kind], 0

    def alu(self, op: int, src, p=None, aux: int = 0) -> None:
        bsel, imm = self._src(src)
        self.emit(Instr(op, bsel, imm, aux, p))

    # fmt: off
    def ld(self, src, p=None): self.alu(LD, src, p)
    def add(self, src, p=None): self.alu(ADD, src, p)
    def adc(self, src, p=None): self.alu(ADC, src, p)
    def sub(self, src, p=None): self.alu(SUB, src, p)
    def sbc(self, src, p=None): self.alu(SBC, src, p)
    def and_(self, src, p=None): self.alu(AND, src, p)
    def shr(self, amount: int, src, p=None): self.alu(SHR, src, p, SHIFT[amount])
    # fmt: on

    def mul(self, src) -> None:
        self.alu(MUL, src)
        self.emit(Instr(NOP))
        self.emit(Instr(NOP))

    def st(self, addr: int, p=None) -> None:
        self.emit(Instr(ST, B_RAM, addr, 0, p))

    def product(self, x, y, lo: int, hi: int) -> None:
        """lo, hi = the low and high words of x * y (the multiplier's 32-bit product)."""
        self.ld(x)
        self.mul(y)
        self.ld(("plo",))
        self.st(lo)
        self.ld(("phi",))
        self.st(hi)

    def less(self, flag: int, a, b) -> None:
        """flag = the sign of a - b, two 32-bit words given as (low, high) operands: a subtract,
        a subtract with borrow, the sign flag (a < b wherever the difference fits 32 bits)."""
        self.ld(a[0])
        self.sub(b[0])
        self.ld(a[1])
        self.sbc(b[1])
        self.setf(flag, C_S)

    def out(self, fld: int, p=None) -> None:
        self.emit(Instr(OUT, 0, 0, fld, p))

    def setf(self, flag: int, cond: int, inv: bool = False, p=None):
        imm = cond | (0x8 if inv else 0)
        self.emit(Instr(SETF, 0, imm, flag, p))

    def hold(self, on: bool) -> None:
        """The bus's reads wait (on) or no longer (off)."""
        self.emit(Instr(HOLD, 0, int(on)))

    def end(self) -> None:
        self.emit(Instr(END))
        self.emit(Instr(NOP))  # fetched after END, never executed

    def bitflag(self, flag: int, bit: int) -> None:
        """flag = bit `bit` of the channel's event word copy."""
        self.ld(C_EV)
        self.and_(("imm", 1 << bit))
        self.add(("imm", 0))
        self.setf(flag, C_Z, inv=True)


# Scratchpad: the channel's words.
(
    C_TC,
    C_KFF,
    C_KP,
    C_KI,
    C_LIM,
    C_SLEW,
    C_WDT,
    C_OFFL,
    C_OFFH,
    C_GAIN,
    C_MINL,
    C_MINH,
    C_MAXL,
    C_MAXH,
    C_STALE,
    C_OC,
    C_TCMIN,
    C_UFF,
    C_EV,
) = range(19)
S_STALE, S_WDT, S_OC, S_FAULT, S_U, S_SAT, S_IL, S_IH, S_TCE = range(20, 29)
# Shared temporaries.
_T = iter(range(64))


def _t() -> int:
    return SHARED | next(_T)


(
    T_DET,
    T_IPL,
    T_IPH,
    T_A,
    T_B,
    T_XL,
    T_XH,
    T_TS,
    T_TCE,
    T_DL,
    T_DH,
    T_HI,
    T_LO,
    T_P1L,
    T_P1H,
    T_2L,
    T_2H,
    T_QL,
    T_QH,
    T_SL,
    T_SH,
    T_TL,
    T_TH,
    T_TIN,
    T_E,
    T_FFL,
    T_FFH,
    T_PPL,
    T_PPH,
    T_PIL,
    T_PIH,
    T_STL,
    T_STH,
    T_STX,
    T_IPX,
    T_ISL,
    T_ISH,
    T_ISX,
    T_INL,
    T_INH,
    T_I7L,
    T_I7H,
    T_I7X,
    T_FFX,
    T_PPX,
    T_WL,
    T_WH,
    T_WX,
    T_RL,
    T_RH,
    T_UX,
    T_US,
    T_SATW,
    T_STR,
    T_OCI,
    T_OCR,
    T_UR,
    T_FB,
    T_X,
    T_STAT,
) = [_t() for _ in range(60)]

COPY = [
    (F_TC, C_TC),
    (F_KFF, C_KFF),
    (F_KP, C_KP),
    (F_KI, C_KI),
    (F_LIM, C_LIM),
    (F_SLEW, C_SLEW),
    (F_WDT, C_WDT),
    (F_OFF, C_OFFL),
    (F_GAIN, C_GAIN),
    (F_MIN, C_MINL),
    (F_MAX, C_MAXL),
    (F_STALE, C_STALE),
    (F_OC, C_OC),
    (F_TCMIN, C_TCMIN),
    (F_UFF, C_UFF),
]
WIDE = {F_OFF: C_OFFH, F_MIN: C_MINH, F_MAX: C_MAXH}


def phase0(a: Asm) -> None:
    """Copy the channel's configuration fields and control bits into its scratchpad words."""
    for f, addr in COPY:
        a.ld(("cfg", f))
        a.st(addr)
        if f in WIDE:
            a.ld(("cfg", f, True))
            a.st(WIDE[f])
    a.ld(("ev", 2))
    a.st(C_EV)
    a.end()


def phase1(a: Asm) -> None:
    """One sample of the channel (TensionLoopModel.tick)."""
    F0, F1, F2, F3, F4, F5, F6, F7 = range(8)
    T, N_ = True, False
    # Counters: fault clear F0, fresh F1, enable F2, TC written F3.
    a.bitflag(F0, EV_FCLR)
    a.bitflag(F1, EV_FRESH)
    a.bitflag(F2, EV_ENABLE)
    a.bitflag(F3, EV_TCW)
    a.ld(S_STALE)
    a.ld(("imm", 0), p=(F0, T))
    a.add(("imm", 1))
    a.setf(F4, C_C)
    a.ld(("imm", M16), p=(F4, T))
    a.ld(("imm", 0), p=(F1, T))
    a.st(S_STALE)
    a.ld(S_WDT)
    a.ld(("imm", 0), p=(F0, T))
    a.add(("imm", 1))
    a.setf(F4, C_C)
    a.ld(("imm", M16), p=(F4, T))
    a.ld(("imm", 0), p=(F3, T))
    a.ld(("imm", 0), p=(F2, N_))
    a.st(S_WDT)
    a.ld(S_OC)
    a.ld(("imm", 0), p=(F0, T))
    a.st(S_OC)
    # Detection (T_DET), only with ENABLE. count >= threshold != 0 as threshold - 1 < count,
    # unsigned: a threshold of 0 wraps to 0xFFFF, which no count exceeds.
    a.ld(C_STALE)
    a.sub(("imm", 1))
    a.sub(S_STALE)
    a.setf(F4, C_C, inv=True)
    a.ld(("imm", 0))
    a.ld(("imm", 1), p=(F4, T))
    a.st(T_DET)
    a.less(F4, (("ev", 0), ("ev", 1)), (C_MINL, C_MINH))
    a.less(F6, (C_MAXL, C_MAXH), (("ev", 0), ("ev", 1)))
    a.setf(F4, C_ZERO, inv=True, p=(F6, T))
    a.ld(T_DET)
    a.add(("imm", 2), p=(F4, T))
    a.st(T_DET)
    a.ld(C_WDT)
    a.sub(("imm", 1))
    a.sub(S_WDT)
    a.setf(F4, C_C, inv=True)
    a.ld(T_DET)
    a.add(("imm", 4), p=(F4, T))
    a.st(T_DET)
    a.ld(C_OC)
    a.sub(("imm", 1))
    a.sub(S_OC)
    a.setf(F4, C_C, inv=True)
    a.ld(T_DET)
    a.add(("imm", 8), p=(F4, T))
    a.ld(("imm", 0), p=(F2, N_))
    a.st(T_DET)
    # FAULT = base | detected, with base 0 after a clear: base + (detected - (detected & base)).
    a.ld(S_FAULT)
    a.ld(("imm", 0), p=(F0, T))
    a.st(T_FB)
    a.ld(T_DET)
    a.and_(T_FB)
    a.st(T_X)
    a.ld(T_DET)
    a.sub(T_X)
    a.add(T_FB)
    a.st(S_FAULT)
    # Mode: run F7, ramp F5 (group stop F6).
    a.bitflag(F6, EV_GRP)
    a.ld(S_FAULT)
    a.add(("imm", 0))
    a.setf(F7, C_Z)
    a.setf(F7, C_ZERO, p=(F6, T))
    a.setf(F7, C_ZERO, p=(F2, N_))
    a.ld(S_FAULT)
    a.sub(("imm", 4))
    a.setf(F5, C_Z)
    a.ld(S_FAULT)
    a.add(("imm", 0))
    a.setf(F4, C_Z)
    a.setf(F4, C_ZERO, p=(F6, N_))
    a.setf(F5, C_ZERO, inv=True, p=(F4, T))
    a.setf(F5, C_ZERO, p=(F2, N_))
    # The integrator entering the sample (INTEG_RESET: 0).
    a.bitflag(F4, EV_IRST)
    a.ld(S_IL)
    a.ld(("imm", 0), p=(F4, T))
    a.st(T_IPL)
    a.ld(S_IH)
    a.ld(("imm", 0), p=(F4, T))
    a.st(T_IPH)
    # Slew limit (SLEW_EN F6): x = TC - T_c'[n-1] in two words, clamped to +-SLEW.
    a.bitflag(F6, EV_SLEW_EN)
    a.ld(C_TC)
    a.ld(("sgn",))
    a.st(T_A)
    a.ld(S_TCE)
    a.ld(("sgn",))
    a.st(T_B)
    a.ld(C_TC)
    a.sub(S_TCE)
    a.st(T_XL)
    a.ld(T_A)
    a.sbc(T_B)
    a.st(T_XH)
    a.less(F1, (C_SLEW, ("imm", 0)), (T_XL, T_XH))
    a.ld(T_XL)
    a.add(C_SLEW)
    a.ld(T_XH)
    a.adc(("imm", 0))
    a.setf(F3, C_S)
    a.setf(F1, C_ZERO, p=(F6, N_))
    a.setf(F3, C_ZERO, p=(F6, N_))
    a.ld(C_TC)
    a.ld(S_TCE, p=(F1, T))
    a.add(C_SLEW, p=(F1, T))
    a.ld(S_TCE, p=(F3, T))
    a.sub(C_SLEW, p=(F3, T))
    a.st(T_TS)
    # The floor.
    a.ld(T_TS)
    a.sub(C_TCMIN)
    a.setf(F4, C_S)
    a.ld(T_TS)
    a.ld(C_TCMIN, p=(F4, T))
    a.st(T_TCE)
    # T_in = sat16((hi*g << 9) + lo*g + 2^19 >> 20), hi = diff >> 9, lo = diff & 511.
    a.ld(("ev", 0))
    a.sub(C_OFFL)
    a.st(T_DL)
    a.ld(("ev", 1))
    a.sbc(C_OFFH)
    a.st(T_DH)
    a.ld(T_DL)
    a.shr(9, T_DH)
    a.st(T_HI)
    a.ld(T_DL)
    a.and_(("imm", 0x1FF))
    a.st(T_LO)
    a.product(T_HI, C_GAIN, T_P1L, T_P1H)
    a.ld(T_LO)
    a.mul(C_GAIN)
    a.ld(("plo",))
    a.st(T_2L)
    a.ld(("phi",))
    a.add(("imm", 8))
    a.st(T_2H)
    a.ld(T_2L)
    a.shr(9, T_2H)
    a.st(T_QL)
    a.ld(T_2H)
    a.shr(9, ("sgn",))
    a.st(T_QH)
    a.ld(T_P1L)
    a.add(T_QL)
    a.st(T_SL)
    a.ld(T_P1H)
    a.adc(T_QH)
    a.st(T_SH)
    a.ld(T_SL)
    a.shr(11, T_SH)
    a.st(T_TL)
    a.ld(T_SH)
    a.shr(11, ("sgn",))
    a.st(T_TH)
    a.less(F1, (("imm", 0x7FFF), ("imm", 0)), (T_TL, T_TH))
    a.ld(T_TL)
    a.add(("imm", 0x8000))
    a.ld(T_TH)
    a.adc(("imm", 0))
    a.setf(F3, C_S)
    a.ld(T_TL)
    a.ld(("imm", 0x7FFF), p=(F1, T))
    a.ld(("imm", 0x8000), p=(F3, T))
    a.st(T_TIN)
    # e = sat16(T_c' - T_in).
    a.ld(T_TCE)
    a.sub(T_TIN)
    a.setf(F4, C_S)
    a.setf(F1, C_V)
    a.setf(F1, C_ZERO, p=(F4, T))
    a.setf(F3, C_V)
    a.setf(F3, C_ZERO, p=(F4, N_))
    a.ld(("imm", 0x7FFF), p=(F1, T))
    a.ld(("imm", 0x8000), p=(F3, T))
    a.st(T_E)
    # Products.
    a.product(T_TCE, C_KFF, T_FFL, T_FFH)
    a.product(T_E, C_KP, T_PPL, T_PPH)
    a.product(T_E, C_KI, T_PIL, T_PIH)
    # Windup (F1): clipped high and KI_TS*e > 0, or low and < 0.
    a.ld(S_SAT)
    a.and_(("imm", 1))
    a.add(("imm", 0))
    a.setf(F1, C_Z, inv=True)
    a.ld(S_SAT)
    a.and_(("imm", 2))
    a.add(("imm", 0))
    a.setf(F3, C_Z, inv=True)
    a.ld(T_PIL)
    a.add(("imm", 0))
    a.ld(T_PIH)
    a.adc(("imm", 0))
    a.setf(F4, C_LE)
    a.setf(F1, C_ZERO, p=(F4, T))
    a.setf(F4, C_S)
    a.setf(F3, C_ZERO, p=(F4, N_))
    a.setf(F1, C_ZERO, inv=True, p=(F3, T))
    a.ld(T_PIL)
    a.ld(("imm", 0), p=(F1, T))
    a.st(T_STL)
    a.ld(T_PIH)
    a.ld(("imm", 0), p=(F1, T))
    a.st(T_STH)
    a.ld(T_STH)
    a.ld(("sgn",))
    a.st(T_STX)
    a.ld(T_IPH)
    a.ld(("sgn",))
    a.st(T_IPX)
    a.ld(T_IPL)
    a.add(T_STL)
    a.st(T_ISL)
    a.ld(T_IPH)
    a.adc(T_STH)
    a.st(T_ISH)
    a.ld(T_IPX)
    a.adc(T_STX)
    a.st(T_ISX)
    # Clamp to +-I_LIMIT << 16.
    a.ld(("imm", 0))
    a.sub(T_ISL)
    a.ld(C_LIM)
    a.sbc(T_ISH)
    a.ld(("imm", 0))
    a.sbc(T_ISX)
    a.setf(F1, C_S)
    a.ld(T_ISL)
    a.add(("imm", 0))
    a.ld(T_ISH)
    a.adc(C_LIM)
    a.ld(T_ISX)
    a.adc(("imm", 0))
    a.setf(F3, C_S)
    a.ld(T_ISL)
    a.ld(("imm", 0), p=(F1, T))
    a.ld(("imm", 0), p=(F3, T))
    a.st(T_INL)
    a.ld(T_ISH)
    a.ld(C_LIM, p=(F1, T))
    a.ld(("imm", 0), p=(F3, T))
    a.sub(C_LIM, p=(F3, T))
    a.st(T_INH)
    # r = ((ff + pp + 256 + (I' >> 7)) >> 9) + UFF, three words before the shift.
    a.ld(T_INL)
    a.shr(7, T_INH)
    a.st(T_I7L)
    a.ld(T_INH)
    a.shr(7, ("sgn",))
    a.st(T_I7H)
    a.ld(T_I7H)
    a.ld(("sgn",))
    a.st(T_I7X)
    a.ld(T_FFH)
    a.ld(("sgn",))
    a.st(T_FFX)
    a.ld(T_PPH)
    a.ld(("sgn",))
    a.st(T_PPX)
    a.ld(T_FFL)
    a.add(T_PPL)
    a.st(T_WL)
    a.ld(T_FFH)
    a.adc(T_PPH)
    a.st(T_WH)
    a.ld(T_FFX)
    a.adc(T_PPX)
    a.st(T_WX)
    a.ld(T_WL)
    a.add(T_I7L)
    a.st(T_WL)
    a.ld(T_WH)
    a.adc(T_I7H)
    a.st(T_WH)
    a.ld(T_WX)
    a.adc(T_I7X)
    a.st(T_WX)
    a.ld(T_WL)
    a.add(("imm", 256))
    a.st(T_WL)
    a.ld(T_WH)
    a.adc(("imm", 0))
    a.st(T_WH)
    a.ld(T_WX)
    a.adc(("imm", 0))
    a.st(T_WX)
    a.ld(T_WL)
    a.shr(9, T_WH)
    a.st(T_RL)
    a.ld(T_WH)
    a.shr(9, T_WX)
    a.st(T_RH)
    a.ld(C_UFF)
    a.ld(("sgn",))
    a.st(T_UX)
    a.ld(T_RL)
    a.add(C_UFF)
    a.st(T_RL)
    a.ld(T_RH)
    a.adc(T_UX)
    a.st(T_RH)
    # u = clamp(r, +-I_LIMIT): high F1, low F3.
    a.less(F1, (C_LIM, ("imm", 0)), (T_RL, T_RH))
    a.ld(T_RL)
    a.add(C_LIM)
    a.ld(T_RH)
    a.adc(("imm", 0))
    a.setf(F3, C_S)
    a.ld(T_RL)
    a.ld(C_LIM, p=(F1, T))
    a.ld(("imm", 0), p=(F3, T))
    a.sub(C_LIM, p=(F3, T))
    a.st(T_US)
    a.ld(("imm", 0))
    a.add(("imm", 1), p=(F1, T))
    a.add(("imm", 2), p=(F3, T))
    a.st(T_SATW)
    a.ld(("imm", 1))
    a.add(("imm", 2), p=(F1, T))
    a.add(("imm", 2), p=(F3, T))
    a.st(T_STR)
    # Over-current count: clipped, +1 to 0xFFFF; else 0.
    a.ld(S_OC)
    a.add(("imm", 1))
    a.setf(F4, C_C)
    a.ld(("imm", M16), p=(F4, T))
    a.setf(F1, C_ZERO, inv=True, p=(F3, T))
    a.ld(("imm", 0), p=(F1, N_))
    a.st(T_OCR)
    # The ramp of u: F1 u > step, F3 u < -step.
    a.ld(("step",))
    a.sub(S_U)
    a.setf(F1, C_S)
    a.ld(S_U)
    a.add(("step",))
    a.setf(F3, C_S)
    a.ld(("imm", 0))
    a.ld(S_U, p=(F1, T))
    a.sub(("step",), p=(F1, T))
    a.ld(S_U, p=(F3, T))
    a.add(("step",), p=(F3, T))
    a.st(T_UR)
    # The sample's results: run F7, else ramp F5 (drive on while the ramp's u is not 0, F1),
    # into the channel's state words, then into its outputs in one block under HOLD (the bus
    # takes no read there, so a read sees a channel's outputs all before or all after it).
    a.ld(("imm", 0))
    a.ld(T_UR, p=(F5, T))
    a.ld(T_US, p=(F7, T))
    a.st(S_U)
    a.setf(F1, C_ZERO, inv=True, p=(F3, T))
    a.setf(F1, C_ZERO, p=(F5, N_))
    a.ld(("imm", 0))
    a.ld(("imm", 5), p=(F1, T))
    a.ld(T_STR, p=(F7, T))
    a.st(T_STAT)
    a.ld(("imm", 0))
    a.ld(T_SATW, p=(F7, T))
    a.st(S_SAT)
    a.ld(("imm", 0))
    a.ld(T_INL, p=(F7, T))
    a.st(S_IL)
    a.ld(("imm", 0))
    a.ld(T_INH, p=(F7, T))
    a.st(S_IH)
    a.ld(("imm", 0))
    a.ld(T_TCE, p=(F7, T))
    a.st(S_TCE)
    a.ld(("imm", 0))
    a.ld(T_OCR, p=(F7, T))
    a.st(S_OC)
    a.hold(True)
    for word, fld in [
        (T_TIN, O_TIN),
        (S_FAULT, O_FAULT),
        (S_U, O_U),
        (T_STAT, O_STATUS),
        (S_IL, O_IL),
        (S_IH, O_IH),
        (S_TCE, O_TCE),
    ]:
        a.ld(word)
        a.out(fld)
    a.hold(False)
    a.end()


# fmt: on


@dataclass
class Program:
    words: list[int]
    entry1: int
    len0: int  # clocks of a channel's phase 0 run (its words to the END, and one)
    len1: int

    def latency(self, n: int) -> int:
        """Clocks from the tick to out_valid for n channels: the tick's and the first fetch's,
        then every run."""
        return 1 + n * (self.len0 + self.len1)


def _check_shared(run: list[Instr]) -> None:
    """Every shared word a run reads it has written before, unpredicated: so no channel's run
    reads what another channel's left there (the channels meet only in their own words)."""
    written: set[int] = set()
    for k, ins in enumerate(run):
        r = ins.reads_ram()
        if r is not None and r & SHARED and r not in written:
            raise SystemExit(f"instruction {k} reads shared word {r:#x} before the run writes it")
        if ins.op == ST and ins.imm & SHARED and ins.pred is None:
            written.add(ins.imm & 0xBF)


def assemble() -> Program:
    a0 = Asm()
    a0.emit(Instr(NOP))  # the entry: reads for the first instruction
    phase0(a0)
    a1 = Asm()
    a1.emit(Instr(NOP))
    phase1(a1)
    entry1 = len(a0.code)
    code = a0.code + a1.code
    for run in (a0.code, a1.code):
        _check_shared(run)
    # ROM word k: instruction k and, in bits 39:32, what instruction k + 1 reads.
    words = [
        code[k].word() | ((code[k + 1].pre() if k + 1 < len(code) else 0) << 32)
        for k in range(len(code))
    ]
    if len(words) > ROM_WORDS:
        raise SystemExit(f"program of {len(words)} words: the ROM holds {ROM_WORDS}")
    # A run: the fetch of its first instruction, then one a clock to the END, whose clock ends it
    # (the END is the last-but-one word: a NOP follows it).
    # A run executes its words to the END (the NOP after it never) and one clock after the END
    # fetches the next entry.
    return Program(words, entry1, len0=len(a0.code), len1=len(a1.code))


# --- the engine, instruction by instruction -------------------------------------------------


def _s16(x: int) -> int:
    x &= M16
    return x - 0x10000 if x & 0x8000 else x


@dataclass
class Engine:
    n: int
    step: int = 41
    sp: list[int] = field(default_factory=lambda: [0] * 256)
    acc: int = 0
    c: int = 0
    z: int = 0
    s: int = 0
    v: int = 0
    flags: list[int] = field(default_factory=lambda: [0] * 8)
    p: int = 0
    outs: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        for ch in range(self.n):
            self.outs[ch] = {k: 0 for k in range(7)}

    def run(self, prog: Program, entry: int, ch: int, cfg_word, ev) -> None:
        """One run from `entry` to its END. cfg_word(f) is the channel's field word (32 bits);
        ev(k) the event source's words."""
        pending: list[tuple[int, int]] = []  # (instruction index it becomes readable, product)
        i = entry
        t = 0
        while True:
            w = prog.words[i] & 0xFFFFFFFF
            t += 1
            for due, val in list(pending):
                if due <= t:
                    self.p = val
                    pending.remove((due, val))
            op, bsel, pr, aux, imm = w >> 28, (w >> 25) & 7, (w >> 20) & 31, (w >> 16) & 15, w & M16
            i += 1
            if pr & 0x10 and self.flags[pr & 7] != ((pr >> 3) & 1):
                continue
            addr = (0xC0 | (imm & 63)) if imm & 0x80 else ((ch << 6) | (imm & 63))
            if bsel == B_RAM:
                b = self.sp[addr]
            elif bsel == B_IMM:
                b = imm
            elif bsel == B_PLO:
                b = self.p & M16
            elif bsel == B_PHI:
                b = (self.p >> 16) & M16
            elif bsel == B_CFG:
                cw = cfg_word(imm & 15)
                b = (
                    (((cw >> 16) & 0xFF) | (0xFF00 if cw & 0x800000 else 0))
                    if imm & 0x10
                    else cw & M16
                )
            elif bsel == B_EV:
                b = ev(imm & 3)
            elif bsel == B_SGN:
                b = M16 if self.acc & 0x8000 else 0
            else:
                b = self.step & M16
            if op == END:
                return
            if op == LD:
                self.acc = b
            elif op in (ADD, ADC, SUB, SBC):
                sub = op in (SUB, SBC)
                cin = 0 if op == ADD else 1 if op == SUB else self.c
                bx = (~b & M16) if sub else b
                tot = self.acc + bx + cin
                res = tot & M16
                ovf = int((self.acc >> 15) == (bx >> 15) and (res >> 15) != (self.acc >> 15))
                self.z = int(res == 0 and (op in (ADD, SUB) or self.z))
                self.c = tot >> 16
                self.s = (res >> 15) ^ ovf
                self.v = ovf
                self.acc = res
            elif op == AND:
                self.acc &= b
            elif op == SHR:
                k = SHIFT_BY[aux & 3] if (aux & 3) in SHIFT_BY else 11
                self.acc = (((b << 16) | self.acc) >> k) & M16
            elif op == SETF:
                cond = [self.s, self.z, self.c, self.s | self.z, self.v, 0, 0, 0][imm & 7]
                cond ^= (imm >> 3) & 1
                self.flags[aux & 7] = cond
            elif op == ST:
                self.sp[addr] = self.acc
            elif op == MUL:
                pending.append((t + 3, (_s16(self.acc) * _s16(b)) & 0xFFFFFFFF))
            elif op == OUT:
                self.outs[ch][aux] = self.acc


def simulate_period(eng: Engine, prog: Program, cfg: list[dict[str, int]], ev: list[dict]) -> None:
    """One period of the engine: cfg[k] channel k's register values (TensionLoopModel.regs
    names), ev[k] its events taken at the tick: raw, enable, slew_en, fresh, tcw, irst, fclr,
    grp."""
    widths = [16, 16, 16, 16, 15, 15, 16, 24, 16, 24, 24, 16, 16, 16, 16]

    def word(k: int):
        return lambda f: cfg[k][CFG_NAMES[f]] & ((1 << widths[f]) - 1)

    def evs(k: int):
        e = ev[k]
        raw = e["raw"] & 0xFFFFFF
        bits = sum(
            int(bool(e[name])) << i
            for i, name in enumerate(["enable", "slew_en", "fresh", "tcw", "irst", "fclr", "grp"])
        )
        srcs = [raw & M16, ((raw >> 16) & 0xFF) | (0xFF00 if raw & 0x800000 else 0), bits, bits]
        return lambda i: srcs[i]

    for k in range(eng.n):
        eng.run(prog, 0, k, word(k), evs(k))
    for k in range(eng.n):
        eng.run(prog, prog.entry1, k, word(k), evs(k))


def write_rom(prog: Program, path: Path = ROM_FILE) -> str:
    lines = [
        "// Generated by `python -m hdl.seq.program` (hdl/seq/program.py): do not edit.",
        "//",
        f"// tension_loop_seq's microprogram: phase 0 at 0 ({prog.entry1} words), phase 1 at",
        f"// {prog.entry1} ({len(prog.words) - prog.entry1} words); a channel's run takes"
        f" {prog.len0} + {prog.len1} clocks.",
        "",
        "`resetall",
        "`timescale 1ns / 1ps",
        "`default_nettype none",
        "",
        "module tension_loop_seq_rom (",
        "    input  wire        clk,",
        "    input  wire [8:0]  addr,",
        "    output reg  [39:0] data,   // the word at addr, the clock after",
        "    output wire [8:0]  entry1  // phase 1's first word",
        ");",
        "",
        f"assign entry1 = 9'd{prog.entry1};",
        "",
        '(* ram_style = "block" *) reg [39:0] mem [0:511];',
        "integer i;",
        "initial begin",
        "    for (i = 0; i < 512; i = i + 1) mem[i] = 40'd0;",
    ]
    lines += [f"    mem[{i}] = 40'h{w:010x};" for i, w in enumerate(prog.words)]
    lines += [
        "end",
        "",
        "always @(posedge clk) data <= mem[addr];",
        "",
        "endmodule",
        "",
        "`resetall",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="fail when the ROM file is stale")
    args = ap.parse_args(argv)
    prog = assemble()
    text = write_rom(prog)
    if args.check:
        if not ROM_FILE.exists() or ROM_FILE.read_text() != text:
            print(f"{ROM_FILE} is stale: run python -m hdl.seq.program", file=sys.stderr)
            return 1
        return 0
    ROM_FILE.write_text(text)
    print(
        f"{ROM_FILE.name}: {len(prog.words)} words, a channel {prog.len0} + {prog.len1} clocks,"
        f" {prog.latency(2)} clocks from the tick to out_valid for 2 channels"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
