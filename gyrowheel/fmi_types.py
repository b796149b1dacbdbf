"""The whole numbers an FMU's integer variable takes: its type's range, its declared range, and
a value given as an int, a float or text read as the whole number it is.

FMI 2.0's Integer (and Enumeration) is 32 bits (fmi2Integer, FMI 2.0.4 section 2.1.2); FMI
3.0's integer types are named by their bits (FMI 3.0.2 section 2.2.1). A variable may narrow its
type's range with min and max (FMI 2.0.4 section 2.2.7, FMI 3.0.2 section 2.4.7.5). ctypes
would wrap a value outside the type's range (3000000000 reaching the FMU as -1294967296), so
gyrowheel.simulate and the system master refuse it first, naming the variable's range.

Only the standard library is used: every room may import this module.
"""
from __future__ import annotations

FMI3_INTEGERS = ("Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64")


def integer_range(fmi_type: str) -> tuple[int, int]:
    """[low, high) of a whole-number type, outside which ctypes would wrap the value: FMI 3.0's
    by their bits; fmi2Integer and Enumerations 32 bits (an FMI 3.0 enumeration is an Int64, but
    the range is kept to what both versions hold)."""
    if fmi_type in FMI3_INTEGERS:
        bits = int(fmi_type.removeprefix("U").removeprefix("Int"))
        return (0, 2**bits) if fmi_type.startswith("U") else (-2**(bits - 1), 2**(bits - 1))
    return (-2**31, 2**31)


def declared_range(v) -> tuple[int, int]:
    """[low, high], both included: the whole numbers variable v (fmpy's ModelVariable, or any
    object with `type` and optionally `min`, `max` as text) takes: its declared min and max
    within its type's range (integer_range). The wheel's max_internal_steps: (1, 2147483647)."""
    low, high = integer_range(v.type)
    high -= 1
    declared_min, declared_max = getattr(v, "min", None), getattr(v, "max", None)
    if declared_min is not None:
        low = max(low, int(declared_min))
    if declared_max is not None:
        high = min(high, int(declared_max))
    return low, high


def whole_number(value) -> int:
    """value as the whole number it is: an int, a float without a fractional part (3e9), or
    text of either ('12', '1e10', ' 7 '). Raises ValueError for anything else: 1.5, '1.5',
    'abc', True (a bool is no number here), inf, nan; nothing is truncated."""
    if isinstance(value, bool) or type(value).__name__ == "bool_":
        raise ValueError(f"{value!r} is no whole number")
    if isinstance(value, int):
        return value
    if isinstance(value, str):
        try:
            return int(value.strip())
        except ValueError:
            pass
    try:
        number = float(value)
    except TypeError:
        raise ValueError(f"{value!r} is no whole number") from None
    if not number.is_integer():  # (inf and nan are not)
        raise ValueError(f"{value!r} is no whole number")
    return int(number)


def out_of_range(v, number: int) -> str:
    """'' when the whole number fits v's type (integer_range), else the words naming v's range
    (declared_range) for the caller's message: 'out of range [1, 2147483647] (Integer)'."""
    low, high = integer_range(v.type)
    if low <= number < high:
        return ""
    low, high = declared_range(v)
    return f"out of range [{low}, {high}] ({v.type})"
