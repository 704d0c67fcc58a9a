"""One-line mutants of a Python module, found with the standard library's ``ast``.

Each mutant is one small edit of the source text at an AST node's position (Jia & Harman, "An
analysis and survey of the development of mutation testing", IEEE TSE 37(5), 2011, sec. II: the
relational, arithmetic, logical, constant and statement-deletion operators). The edit keeps the
rest of the file byte-identical, so a survivor is reported as the one line a reader compares.

Operators: a comparison flipped or relaxed (``<`` to ``<=``/``>=``, ``==`` to ``!=``, ``in`` to
``not in``); arithmetic ``+ - * / // **`` swapped (also in ``+=``); ``and``/``or`` swapped; a
``not`` or unary minus removed; a numeric literal set to 0, n+1 or 2x; a return value replaced by
``None`` (and a truth value negated); ``continue``, ``break`` and call statements deleted; a
slice bound moved by one."""
import ast
from dataclasses import dataclass

#: relational operators and what each is mutated to (flipped and relaxed/tightened)
COMPARE = {"<": ("<=", ">="), "<=": ("<", ">"), ">": (">=", "<="), ">=": (">", "<"),
           "==": ("!=",), "!=": ("==",), "is": ("is not",), "is not": ("is",),
           "in": ("not in",), "not in": ("in",)}
_CMP_TEXT = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!=",
             ast.Is: "is", ast.IsNot: "is not", ast.In: "in", ast.NotIn: "not in"}
#: arithmetic operators and their replacement
ARITH = {ast.Add: ("+", "-"), ast.Sub: ("-", "+"), ast.Mult: ("*", "/"), ast.Div: ("/", "*"),
         ast.FloorDiv: ("//", "*"), ast.Pow: ("**", "*")}
_BOOL = {ast.And: ("and", "or"), ast.Or: ("or", "and")}


@dataclass(frozen=True)
class Mutant:
    """One edit: source ``[start, end)`` (character offsets) replaced by ``text``; ``line`` is the
    1-based line of the edit, ``operator`` names the kind of edit."""
    path: str
    line: int
    start: int
    end: int
    text: str
    operator: str

    def apply(self, source: str) -> str:
        return source[:self.start] + self.text + source[self.end:]

    def lines(self, source: str) -> tuple[str, str]:
        """The original and mutated text of the edited line(s), stripped."""
        lo = source.rfind("\n", 0, self.start) + 1
        hi = source.find("\n", self.end)
        hi = len(source) if hi < 0 else hi
        original = source[lo:hi]
        mutated = original[:self.start - lo] + self.text + original[self.end - lo:]
        return " ".join(original.split()), " ".join(mutated.split())


class _Offsets:
    """(line, column) of ``ast`` (1-based line, UTF-8 byte column) to character offsets."""

    def __init__(self, source: str):
        self.source = source
        self.lines = source.splitlines(keepends=True)
        self.starts = [0]
        for text in self.lines:
            self.starts.append(self.starts[-1] + len(text))

    def at(self, line: int, col: int) -> int:
        text = self.lines[line - 1]
        return self.starts[line - 1] + len(text.encode()[:col].decode(errors="ignore"))

    def span(self, node) -> tuple[int, int]:
        return self.at(node.lineno, node.col_offset), self.at(node.end_lineno, node.end_col_offset)


def _token_in_gap(source: str, lo: int, hi: int, token: str) -> int | None:
    """Offset of the operator ``token`` between two operands (``[lo, hi)`` holds only brackets,
    blanks, comments and the operator), or None."""
    gap = source[lo:hi]
    i = 0
    while i < len(gap):
        ch = gap[i]
        if ch == "#":
            i = gap.find("\n", i)
            if i < 0:
                return None
            continue
        if gap.startswith(token, i):
            after = gap[i + len(token):i + len(token) + 1]
            if not (token[-1].isalpha() and (after.isalnum() or after == "_")) and \
                    not (token[-1] in "<>=!*/" and after in ("=", "*", "/")):
                return lo + i
        i += 1
    return None


def _compare_token(source: str, lo: int, hi: int, op: str) -> tuple[int, int] | None:
    """Span of the comparison ``op`` in the gap (``is not``/``not in`` may hold any blanks)."""
    words = op.split()
    at = _token_in_gap(source, lo, hi, words[0])
    if at is None:
        return None
    end = at + len(words[0])
    if len(words) == 2:
        rest = source[end:hi]
        stripped = rest.lstrip()
        if not stripped.startswith(words[1]):
            return None
        end += len(rest) - len(stripped) + len(words[1])
    return at, end


def _inside_fstring(tree) -> set[int]:
    """ids of the nodes inside f-strings (their positions are not reliable)."""
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr):
            skip.update(id(sub) for sub in ast.walk(node))
    return skip


def _docstrings(tree) -> set[int]:
    return {id(body[0].value) for node in ast.walk(tree)
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
            and (body := node.body) and isinstance(body[0], ast.Expr)
            and isinstance(body[0].value, ast.Constant)}


def _textual(node) -> bool:
    """True for a string, f-string or list display (``+`` on these is joining, not arithmetic)."""
    return isinstance(node, (ast.JoinedStr, ast.List, ast.ListComp)) or \
        (isinstance(node, ast.Constant) and isinstance(node.value, (str, bytes)))


def _number_texts(value) -> list[str]:
    if isinstance(value, int):
        return ["1"] if value == 0 else ["0", repr(value + 1)]
    return ["1.0"] if value == 0.0 else ["0.0", repr(value * 2.0)]


def mutants(path: str, source: str) -> list[Mutant]:
    """Every one-line mutant of ``source`` (the module at ``path``) that still compiles, in source
    order, without duplicates."""
    tree = ast.parse(source)
    at = _Offsets(source)
    skip = _inside_fstring(tree) | _docstrings(tree)
    found: list[Mutant] = []

    def add(start: int, end: int, text: str, operator: str):
        found.append(Mutant(path, source.count("\n", 0, start) + 1, start, end, text, operator))

    def operator_swap(left, right, token: str, new: str, operator: str):
        lo, hi = at.span(left)[1], at.span(right)[0]
        where = _compare_token(source, lo, hi, token)
        if where is not None:
            add(where[0], where[1], new, operator)

    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            for k, op in enumerate(node.ops):
                token = _CMP_TEXT[type(op)]
                for new in COMPARE[token]:
                    operator_swap(operands[k], operands[k + 1], token, new, "compare")
        elif isinstance(node, ast.BinOp) and type(node.op) in ARITH and \
                not (_textual(node.left) or _textual(node.right)):
            token, new = ARITH[type(node.op)]
            operator_swap(node.left, node.right, token, new, "arith")
        elif isinstance(node, ast.AugAssign) and type(node.op) in ARITH and \
                not _textual(node.value):
            token, new = ARITH[type(node.op)]
            operator_swap(node.target, node.value, token + "=", new + "=", "arith")
        elif isinstance(node, ast.BoolOp):
            token, new = _BOOL[type(node.op)]
            for left, right in zip(node.values, node.values[1:]):
                operator_swap(left, right, token, new, "bool")
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.Not, ast.USub)):
            start = at.span(node)[0]
            kind = "not" if isinstance(node.op, ast.Not) else "negate"
            add(start, at.span(node.operand)[0], "", kind)
        elif isinstance(node, ast.Constant) and type(node.value) in (int, float):
            start, end = at.span(node)
            for text in _number_texts(node.value):
                add(start, end, text, "constant")
        elif isinstance(node, ast.Return) and node.value is not None:
            start, end = at.span(node.value)
            if not (isinstance(node.value, ast.Constant) and node.value.value is None):
                add(start, end, "None", "return")
            if isinstance(node.value, (ast.Compare, ast.BoolOp)) or \
                    (isinstance(node.value, ast.UnaryOp) and isinstance(node.value.op, ast.Not)):
                add(start, end, f"not ({source[start:end]})", "return")
        elif isinstance(node, (ast.Continue, ast.Break)) or \
                (isinstance(node, ast.Expr) and isinstance(node.value, ast.Call)):
            start, end = at.span(node)
            add(start, end, "pass", "delete")
        elif isinstance(node, ast.Slice):
            for bound, shift in ((node.lower, "+ 1"), (node.upper, "- 1")):
                if bound is not None:
                    start, end = at.span(bound)
                    add(start, end, f"({source[start:end]}) {shift}", "slice")
    unique, seen = [], set()
    for mutant in sorted(found, key=lambda m: (m.start, m.end, m.text)):
        changed = mutant.apply(source)
        if changed == source or changed in seen:
            continue
        try:
            compile(changed, path, "exec")
        except SyntaxError:
            continue
        seen.add(changed)
        unique.append(mutant)
    return unique
