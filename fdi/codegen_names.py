"""Text from a model file made safe for C source: identifiers, string literals and comments.

A model file is data (docs/security.md): its names (parameters, modes, columns, the model's own)
become C identifiers, string literals and comments in the code ``bgfdi codegen`` writes, and none
of them may change what that code means. Every name goes through one of these functions:

- :func:`identifier`: ASCII letters, digits and ``_`` only (any other character written as its code
  point), never a C keyword (C89 to C23), never a macro the C library or a compiler may define
  (``NAN``, ``errno``, ``linux``), never a reserved spelling (a leading ``_``), unique among the
  names it is allocated with;
- :func:`string_literal`: printable ASCII as it is, everything else (quotes, backslashes, ``?``
  against trigraphs, UTF-8 bytes) as octal escapes;
- :func:`comment`: printable ASCII, with ``*/``, ``/*`` and trigraphs broken apart and line ends
  removed, so a name cannot end the comment it is quoted in.

>>> identifier("int"), identifier("µ0"), identifier("2x"), identifier("NAN"), identifier("k1")
('int_', 'u00b5_0', 'v2x', 'NAN_', 'k1')
>>> print(string_literal('say "µ"?'))
"say \\042\\302\\265\\042\\077"
>>> comment("end */ here /* and ??/")
'end * / here / * and ? ?/'
"""
from __future__ import annotations

import re

# C89 to C23 keywords, and names C99's headers or compilers define as macros in some mode (-std=gnu99
# defines linux and unix; <math.h> defines math_errhandling, <stdio.h> stdin/stdout/stderr as macros)
KEYWORDS = frozenset("""
auto break case char const continue default do double else enum extern float for goto if inline int long
register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while
_Bool _Complex _Imaginary _Alignas _Alignof _Atomic _Generic _Noreturn _Static_assert _Thread_local
alignas alignof bool constexpr false nullptr static_assert thread_local true typeof typeof_unqual
_BitInt _Decimal32 _Decimal64 _Decimal128
asm fortran complex imaginary noreturn offsetof errno assert stdin stdout stderr math_errhandling
linux unix i386 i686 x86_64 amd64 arm aarch64 mips sun sparc vax interrupt near far huge
NULL EOF BUFSIZ INFINITY NAN HUGE_VAL HUGE_VALF HUGE_VALL FILENAME_MAX FOPEN_MAX RAND_MAX TMP_MAX
EXIT_SUCCESS EXIT_FAILURE SEEK_SET SEEK_CUR SEEK_END MB_CUR_MAX CLOCKS_PER_SEC I DECIMAL_DIG
""".split())
# macro families of the C library's headers (<math.h>, <stdint.h>, <inttypes.h>, <errno.h>, <float.h>,
# <limits.h>, <signal.h>) and POSIX's M_PI & co., by prefix
MACRO_PREFIXES = ("E", "FP_", "FE_", "INT", "UINT", "PRI", "SCN", "M_", "MATH_", "HUGE_", "FLT_", "DBL_",
                  "LDBL_", "SIZE_", "PTRDIFF_", "SIG", "WCHAR_", "WINT_", "CHAR_", "SCHAR_", "UCHAR_", "SHRT_",
                  "USHRT_", "LONG_", "ULONG_", "LLONG_", "ULLONG_", "L_", "_IO", "BGFDI")
MAX_LENGTH = 60          # characters of an identifier (C99 guarantees 63 significant ones)


def _ascii(name: str) -> str:
    """``name`` with every character outside [A-Za-z0-9_] written as its code point (``u00b5_``)."""
    out = []
    for ch in str(name):
        if ch.isascii() and (ch.isalnum() or ch == "_"):
            out.append(ch)
        else:
            out.append(f"u{ord(ch):04x}_")
    return "".join(out)


def _macro_like(name: str) -> bool:
    """Whether ``name`` could be a macro of the C library (an upper-case family) or a keyword."""
    if name in KEYWORDS:
        return True
    upper = name.upper() == name
    return upper and any(name.startswith(p) and (len(name) == len(p) or not name[len(p)].islower())
                         for p in MACRO_PREFIXES)


def identifier(name: str, taken: set[str] | None = None) -> str:
    """A valid, safe C identifier for ``name``, not in ``taken`` (which it is then added to)."""
    base = _ascii(name) or "v"
    base = base.lstrip("_") or "v"
    if base[0].isdigit():
        base = "v" + base
    if _macro_like(base):
        base += "_"
    base = base[:MAX_LENGTH]
    out, k = base, 2
    while taken is not None and out in taken:
        out = f"{base[:MAX_LENGTH - 4]}_{k}"
        k += 1
    if taken is not None:
        taken.add(out)
    return out


def string_literal(text: str) -> str:
    """``text`` as a C string literal: its UTF-8 bytes, printable ASCII other than ``"``, ``\\`` and
    ``?`` as themselves, every other byte as a three-digit octal escape (which, unlike ``\\x``,
    never swallows a following digit)."""
    out = []
    for byte in str(text).encode("utf-8"):
        ch = chr(byte)
        if 32 <= byte < 127 and ch not in '"\\?':
            out.append(ch)
        else:
            out.append(f"\\{byte:03o}")
    return '"' + "".join(out) + '"'


def comment(text: str, limit: int | None = None) -> str:
    """``text`` for the inside of a ``/* */`` comment: printable ASCII only (other characters as
    ``\\u`` code points, control characters as spaces), ``*/`` and ``/*`` split, ``??`` split
    (trigraphs), cut to ``limit`` characters with an ellipsis."""
    chars = []
    for ch in str(text):
        if ch in "\r\n\t\f\v" or (ch.isascii() and not ch.isprintable()):
            chars.append(" ")
        elif not ch.isascii():
            chars.append(f"\\u{ord(ch):04x}")
        else:
            chars.append(ch)
    out = "".join(chars)
    while True:
        fixed = out.replace("*/", "* /").replace("/*", "/ *").replace("??", "? ?")
        if fixed == out:
            break
        out = fixed
    out = out.rstrip("\\")                    # a backslash before the line end would splice the next line
    if limit is not None and len(out) > limit:
        out = out[:limit - 3].rstrip("\\") + "..."
    return out


def wrapped(text: str, width: int = 96) -> list[str]:
    """A comment's text cut into lines of at most ``width`` characters, at spaces where there are."""
    words = re.split(r"(?<=[ ,])", comment(text))
    lines, line = [], ""
    for w in words:
        while len(w) > width:                 # one long word (an expression without spaces)
            if line:
                lines.append(line)
                line = ""
            lines.append(w[:width])
            w = w[width:]
        if len(line) + len(w) > width:
            lines.append(line)
            line = ""
        line += w
    if line:
        lines.append(line)
    return [x.rstrip().rstrip("\\") for x in lines] or [""]
