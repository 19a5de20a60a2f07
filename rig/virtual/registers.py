"""Register images of the three virtual devices (CONTRACTS section E).

Each function turns one device sample into the list of 16-bit holding-register
values of that device's whole address space (zero-based). Gaps read as 0.
Byte order inside a register is Modbus big-endian; 32-bit word orders are named
as in CONTRACTS E: ABCD = high word first, CDAB = low word first, BADC = high
word first with the bytes of each word swapped, DCBA = fully reversed.
"""
import math
import struct

FT_UNIT = 9       # force/torque sensor (Robotiq FT 300 style)
STAGE_UNIT = 1    # feed stage (Oriental Motor AZ style)
SPINDLE_UNIT = 2  # spindle

FT_SIZE = 420     # addresses 0..419 exist on unit 9
STAGE_SIZE = 198  # 0..7 current sample, 100..197 FIFO
SPINDLE_SIZE = 5
SPINDLE_LOAD = 4  # int16: load torque in 0.1 % of the rated torque (--spindle-rated-Nmm), like a VFD

FT_INT16 = 180    # Fx,Fy,Fz N*100 ; Mx,My,Mz N*m*1000 (= N*mm)
FT_FLOAT = 200    # Fx,Fy,Fz N, Tx,Ty,Tz N*mm, float32 ABCD
FT_COUNTER = 220  # uint32 ABCD
FT_STATUS = 222   # uint16 status word: bit 0 an int16 value saturated, bit 1 overload (--status-every)
STATUS_SATURATED = 0x0001
STATUS_OVERLOAD = 0x0002
FIFO_COUNTER = 300
FIFO_DATA = 302
FIFO_DEPTH = 8
STAGE_FIFO_COUNTER = 100
STAGE_FIFO_DATA = 102
STAGE_FIFO_DEPTH = 16  # 16 x 6 registers: one request covers 16 samples
# A deep FIFO (--ft-fifo-depth N, off by default): more records than one request's 125
# registers carry, read in several blocks. Each record holds its own counter, so a reader
# whose blocks straddle a new sample (the window moves between requests) still knows
# which record is which: u32 counter ABCD + Fx..Tz float32 ABCD = 14 registers.
# The stage's (--stage-fifo-depth N) at the same addresses on unit 1: u32 counter ABCD +
# x, y, z int32 µm ABCD = 8 registers a record.
DEEP_FIFO_COUNTER = 1000
DEEP_FIFO_DATA = 1002
DEEP_FIFO_RECORD = 14
STAGE_DEEP_FIFO_RECORD = 8
DEEP_FIFO_MAX = 4000
CONST_FLOAT = 400  # 123456.0 in ABCD, CDAB, BADC, DCBA
CONST_INT = 410    # 123456 in ABCD, CDAB, BADC, DCBA
CONST_VALUE = 123456
WORD_ORDERS = ("ABCD", "CDAB", "BADC", "DCBA")

INT16_MAX = 32767


def sat_int16(x):
    """Round and saturate to int16 (a real sensor clips, it never wraps)."""
    if math.isnan(x):
        return 0
    return int(round(max(-INT16_MAX, min(INT16_MAX, x))))


def u16(v):
    """int16 -> the unsigned register value carrying the same bits."""
    return v & 0xFFFF


def words_from_bytes(b4, order):
    """4 big-endian bytes (A B C D) -> two register values in a word order."""
    a, b, c, d = b4
    if order == "ABCD":
        return [(a << 8) | b, (c << 8) | d]
    if order == "CDAB":
        return [(c << 8) | d, (a << 8) | b]
    if order == "BADC":
        return [(b << 8) | a, (d << 8) | c]
    if order == "DCBA":
        return [(d << 8) | c, (b << 8) | a]
    raise ValueError(f"unknown word order {order}")


def u32_words(x):
    """uint32 (wrapping like a device counter), ABCD."""
    x &= 0xFFFFFFFF
    return [x >> 16, x & 0xFFFF]


def i32_words(x):
    """int32, ABCD; saturates instead of wrapping."""
    x = int(round(max(-(2**31), min(2**31 - 1, x))))
    return u32_words(x & 0xFFFFFFFF)


def _constant_block():
    regs = []
    for order in WORD_ORDERS:
        regs += words_from_bytes(struct.pack(">f", float(CONST_VALUE)), order)
    regs_int = []
    for order in WORD_ORDERS:
        regs_int += words_from_bytes(struct.pack(">i", CONST_VALUE), order)
    return regs, regs_int


CONST_FLOAT_REGS, CONST_INT_REGS = _constant_block()


def ft_size(deep_depth):
    """Addresses on unit 9: 0..419, and the deep FIFO's when it is on."""
    return DEEP_FIFO_DATA + DEEP_FIFO_RECORD * deep_depth if deep_depth else FT_SIZE


def stage_size(deep_depth):
    """Addresses on unit 1: 0..197, and the deep FIFO's when it is on."""
    return DEEP_FIFO_DATA + STAGE_DEEP_FIFO_RECORD * deep_depth if deep_depth else STAGE_SIZE


def _deep_fifo(regs, counter, deep, record_len, words):
    """Writes a deep FIFO: the newest counter, then each record's counter and words(value)."""
    regs[DEEP_FIFO_COUNTER:DEEP_FIFO_COUNTER + 2] = u32_words(counter)
    at = DEEP_FIFO_DATA
    for rec in deep:
        if rec is not None:
            regs[at:at + 2] = u32_words(rec[0])
            regs[at + 2:at + record_len] = words(rec[1])
        at += record_len


def ft_image(counter, wrench, fifo, overload=False, deep=()):
    """Unit 9 address space.

    counter: device sample counter of the current sample.
    wrench: (Fx, Fy, Fz N, Tx, Ty, Tz N*mm) of the current sample.
    fifo: the newest FIFO_DEPTH wrenches, oldest first (None = not yet sampled, zeros).
    deep: the deep FIFO's records, (counter, wrench) oldest first (None = not yet sampled).
    """
    regs = [0] * ft_size(len(deep))
    fx, fy, fz, tx, ty, tz = wrench
    regs[FT_INT16:FT_INT16 + 6] = [
        u16(sat_int16(fx * 100.0)), u16(sat_int16(fy * 100.0)), u16(sat_int16(fz * 100.0)),
        # N*m*1000 is numerically N*mm
        u16(sat_int16(tx)), u16(sat_int16(ty)), u16(sat_int16(tz))]
    packed = struct.unpack(">12H", struct.pack(">6f", *wrench))
    regs[FT_FLOAT:FT_FLOAT + 12] = packed
    regs[FT_COUNTER:FT_COUNTER + 2] = u32_words(counter)
    saturated = any(math.isnan(v) or abs(v * s) > INT16_MAX
                    for v, s in zip(wrench, (100.0, 100.0, 100.0, 1.0, 1.0, 1.0)))
    regs[FT_STATUS] = (STATUS_SATURATED if saturated else 0) | (STATUS_OVERLOAD if overload else 0)
    regs[FIFO_COUNTER:FIFO_COUNTER + 2] = u32_words(counter)
    at = FIFO_DATA
    for w in fifo:
        if w is not None:
            regs[at:at + 12] = struct.unpack(">12H", struct.pack(">6f", *w))
        at += 12
    if deep:
        _deep_fifo(regs, counter, deep, DEEP_FIFO_RECORD, lambda w: struct.unpack(">12H", struct.pack(">6f", *w)))
    regs[CONST_FLOAT:CONST_FLOAT + 8] = CONST_FLOAT_REGS
    regs[CONST_INT:CONST_INT + 8] = CONST_INT_REGS
    return regs


def _position_words(position_mm):
    regs = []
    for p in position_mm:
        regs += i32_words(0 if math.isnan(p) else p * 1000.0)
    return regs


def stage_image(counter, position_mm, fifo, deep=()):
    """Unit 1: position x,y,z int32 micrometres ABCD, counter uint32 ABCD; FIFO block.

    fifo: the newest STAGE_FIFO_DEPTH positions, oldest first (None = not yet sampled).
    deep: the deep FIFO's records, (counter, position) oldest first (None = not yet sampled).
    """
    regs = [0] * stage_size(len(deep))
    regs[0:8] = _position_words(position_mm) + u32_words(counter)
    regs[STAGE_FIFO_COUNTER:STAGE_FIFO_COUNTER + 2] = u32_words(counter)
    at = STAGE_FIFO_DATA
    for p in fifo:
        if p is not None:
            regs[at:at + 6] = _position_words(p)
        at += 6
    if deep:
        _deep_fifo(regs, counter, deep, STAGE_DEEP_FIFO_RECORD, _position_words)
    return regs


def spindle_image(counter, rpm, load_Nmm=0.0, rated_Nmm=10.0):
    """Unit 2: |rpm| uint16 (saturated), direction (0 = +, 1 = -), counter, and the drive's
    load torque as a VFD reports it: int16 in 0.1 % of the rated torque (saturated)."""
    if math.isnan(rpm):
        rpm = 0.0
    mag = int(round(min(0xFFFF, abs(rpm))))
    load = 0.0 if math.isnan(load_Nmm) else 1000.0 * load_Nmm / rated_Nmm
    return [mag, 1 if rpm < 0 else 0] + u32_words(counter) + [u16(sat_int16(load))]
