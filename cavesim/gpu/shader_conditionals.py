"""The `#if` branches of an assembled GLSL stage, decided on its text without GL.

The shader gate (`cavesim.gpu.shader_gate`) compiles a few hundred variants of the particle
pass instead of every combination of its defines; this module tells it which branch of
every conditional group each variant's defines take, so that it can show that every
branch (and so every line) is compiled by some variant. A small preprocessor:
`#if/#ifdef/#ifndef/#elif/#else/#endif`, object-like `#define`/`#undef` (a condition may
name a macro the text defines, such as INTEGRATOR_RK4), `defined`, integer arithmetic,
comparisons, `&&`, `||`, `!` and parentheses. As in GLSL, an identifier that no `#define`
gives is an error where it is evaluated (not in the skipped side of `&&` or `||`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache

from cavesim.core.errors import ShaderError

_DIRECTIVE = re.compile(r"\s*#\s*(\w*)(.*)")
_LINE_MARKER = re.compile(r"\s*(\d+)(?:\s+(\d+))?\s*$")
_MACRO = re.compile(r"\s*([A-Za-z_]\w*)(\()?(.*)")
_TOKEN = re.compile(r"\s*(?:(0[xX][0-9a-fA-F]+|\d+)[uU]?(?![\w.])|([A-Za-z_]\w*)"
                    r"|(&&|\|\||==|!=|<=|>=|<<|>>|[-+*/%<>!~&|^()]))")
_COMMENT = re.compile(r"//.*|/\*.*?\*/")
# binary operators by precedence, loosest first (GLSL 4.30 spec, section 3.3)
_BINARY = {op: level for level, ops in enumerate(
    [("||",), ("&&",), ("|",), ("^",), ("&",), ("==", "!="), ("<", ">", "<=", ">="),
     ("<<", ">>"), ("+", "-"), ("*", "/", "%")], start=1) for op in ops}
_FUNCTION_LIKE = object()  # a function-like macro's value: `defined`, never expanded here


@dataclass(frozen=True)
class Branch:
    """One arm of a conditional group: its directive and where it stands (`file.glsl:LINE`).
    An `#if` group without `#else` has an implied one, at its `#endif`: the arm that holds
    nothing, taken when no condition holds."""

    where: str
    directive: str
    lines: int  # the source lines it holds itself, not those of groups inside it

    def __str__(self) -> str:
        return f"{self.where} {self.directive}"


@dataclass(frozen=True)
class Outcome:
    """What one set of defines makes of a stage: the branches taken, the `#error`s reached."""

    taken: frozenset[Branch]
    errors: tuple[str, ...]


@dataclass
class _Arm:
    branch: Branch
    condition: str | None  # the #if/#elif expression; None for #else
    items: list


@dataclass
class _Group:
    arms: list[_Arm]


class Conditionals:
    """The conditional groups of one stage's text, parsed once, decided for many defines."""

    def __init__(self, text: str, files: tuple[str, ...] = ()) -> None:
        self.files = files
        self.items, self.lines = self._parse(text.splitlines())
        self.branches = tuple(_branches(self.items))

    def taken(self, defines: Mapping[str, object]) -> Outcome:
        """The branches `defines` take. They stand for the assembler's injected defines: a
        `#define` of one of their names in the text is overridden, so one variant's text
        stands for every variant of its program."""
        macros: dict[str, object] = {name: str(int(value)) if isinstance(value, bool)
                                     else str(value) for name, value in defines.items()}
        taken: set[Branch] = set()
        errors: list[str] = []
        self._run(self.items, macros, frozenset(macros), taken, errors)
        return Outcome(frozenset(taken), tuple(errors))

    def _run(self, items: list, macros: dict, injected: frozenset, taken: set,
             errors: list) -> None:
        for item in items:
            if isinstance(item, _Group):
                for arm in item.arms:
                    if arm.condition is None or _decide(arm.condition, macros, arm.branch):
                        taken.add(arm.branch)
                        self._run(arm.items, macros, injected, taken, errors)
                        break
            elif item[0] == "define" and item[1] not in injected:
                macros[item[1]] = item[2]
            elif item[0] == "undef" and item[1] not in injected:
                macros.pop(item[1], None)
            elif item[0] == "error":
                errors.append(item[1])

    def _parse(self, lines: list[str]) -> tuple[list, int]:
        """The text as nested groups of directives; the count of its source lines."""
        top: list = []
        stack: list[tuple[_Group, list]] = []  # open groups, and the items around each
        items = top
        files, number, source, total = self.files, 0, 0, 0
        pending: list[int] = [0]  # source lines of the arm being read, by depth
        k = 0
        while k < len(lines):
            line = lines[k]
            number += 1
            where = f"{files[source] if source < len(files) else source}:{number}"
            k += 1
            match = _DIRECTIVE.match(line)
            if match is None:
                if line.strip():
                    total += 1
                    pending[-1] += 1
                continue
            while line.endswith("\\") and k < len(lines):  # a continued directive
                line = line[:-1] + lines[k]
                k += 1
                number += 1
            match = _DIRECTIVE.match(_COMMENT.sub(" ", line))
            name, rest = match[1], " ".join(match[2].split())
            if name in ("if", "ifdef", "ifndef"):
                condition = (rest if name == "if"
                             else f"{'!' if name == 'ifndef' else ''}defined {rest.split()[0]}"
                             if rest else "")
                if not condition:
                    raise ShaderError(f"{where}: #{name} without a condition")
                arm = _Arm(Branch(where, f"#{name} {rest}", 0), condition, [])
                group = _Group([arm])
                items.append(group)
                stack.append((group, items))
                items = arm.items
                pending.append(0)
            elif name in ("elif", "else"):
                if not stack or stack[-1][0].arms[-1].condition is None:
                    raise ShaderError(f"{where}: #{name} without an open #if"
                                      + (" (after #else)" if stack else ""))
                group = stack[-1][0]
                _close_arm(group, pending.pop())
                directive = f"#{name} {rest}".rstrip()
                arm = _Arm(Branch(where, directive, 0), rest if name == "elif" else None, [])
                if name == "elif" and not rest:
                    raise ShaderError(f"{where}: #elif without a condition")
                group.arms.append(arm)
                items = arm.items
                pending.append(0)
            elif name == "endif":
                if not stack:
                    raise ShaderError(f"{where}: #endif without an open #if")
                group, items = stack.pop()
                _close_arm(group, pending.pop())
                if group.arms[-1].condition is not None:
                    opened = group.arms[0].branch
                    group.arms.append(_Arm(Branch(where, f"#endif (no branch of the #if "
                                                         f"at {opened.where})", 0), None, []))
            elif name == "define":
                macro = _MACRO.match(rest)
                if macro is None:
                    raise ShaderError(f"{where}: #define without a name")
                value = _FUNCTION_LIKE if macro[2] else macro[3].strip()
                items.append(("define", macro[1], value))
            elif name == "undef":
                items.append(("undef", rest.split()[0] if rest else ""))
            elif name == "error":
                items.append(("error", f"{where}: #error {rest}"))
            elif name == "line" and (marker := _LINE_MARKER.match(rest)):
                number = int(marker[1]) - 1
                source = int(marker[2]) if marker[2] else source
        if stack:
            raise ShaderError(f"{stack[-1][0].arms[0].branch.where}: #if without #endif")
        return top, total


def _close_arm(group: _Group, lines: int) -> None:
    """Record how many source lines the last arm of `group` holds itself."""
    arm = group.arms[-1]
    arm.branch = Branch(arm.branch.where, arm.branch.directive, lines)


def _branches(items: list):
    for item in items:
        if isinstance(item, _Group):
            for arm in item.arms:
                yield arm.branch
                yield from _branches(arm.items)


def _decide(condition: str, macros: Mapping[str, object], branch: Branch) -> bool:
    """Whether an #if/#elif condition holds under `macros`."""
    try:
        return bool(evaluate(condition, macros))
    except ShaderError as e:
        raise ShaderError(f"{branch}: {e}") from e


def evaluate(condition: str, macros: Mapping[str, object]) -> int:
    """The value of a preprocessor condition; `macros` maps each defined name to its
    replacement text."""
    tokens = _expand(_tokens(condition), macros, frozenset())
    parser = _Parser(tokens)
    tree = parser.expression(0)
    if parser.at < len(tokens):
        raise ShaderError(f"unexpected {tokens[parser.at]!r} in {condition!r}")
    return _value(tree, condition)


@lru_cache(maxsize=4096)
def _tokens(text: str) -> tuple[str | int, ...]:
    """Numbers as ints, names and operators as strings."""
    out: list[str | int] = []
    at = 0
    text = text.rstrip()
    while at < len(text):
        match = _TOKEN.match(text, at)
        if match is None:
            raise ShaderError(f"cannot read {text[at:].strip()!r} in {text!r}")
        number, name, operator = match.groups()
        out.append(int(number, 0) if number and number[:2].lower() == "0x"
                   else int(number, 8) if number and len(number) > 1 and number[0] == "0"
                   else int(number) if number else name or operator)
        at = match.end()
    return tuple(out)


def _expand(tokens: tuple, macros: Mapping[str, object], hidden: frozenset[str]) -> list:
    """`defined` decided, then every macro replaced by its value, again and again; a name
    is not expanded inside its own value (as in C)."""
    out: list = []
    k = 0
    while k < len(tokens):
        token = tokens[k]
        if token == "defined":
            name, k = _defined_operand(tokens, k + 1)
            out.append(int(name in macros))
            continue
        k += 1
        if isinstance(token, str) and token in macros and token not in hidden:
            value = macros[token]
            if value is _FUNCTION_LIKE:
                raise ShaderError(f"function-like macro {token} in a condition")
            out += _expand(_tokens(str(value)), macros, hidden | {token})
        else:
            out.append(token)
    return out


def _defined_operand(tokens: tuple, k: int) -> tuple[str, int]:
    """The name after `defined` (bare or in parentheses), and the index after it."""
    if k < len(tokens) and tokens[k] == "(":
        if k + 2 < len(tokens) and _is_name(tokens[k + 1]) and tokens[k + 2] == ")":
            return tokens[k + 1], k + 3
    elif k < len(tokens) and _is_name(tokens[k]):
        return tokens[k], k + 1
    raise ShaderError("defined needs a name")


def _is_name(token) -> bool:
    return isinstance(token, str) and (token[0].isalpha() or token[0] == "_")


class _Parser:
    """Precedence climbing over the expanded tokens, into a tree evaluated lazily."""

    def __init__(self, tokens: list) -> None:
        self.tokens = tokens
        self.at = 0

    def expression(self, loosest: int):
        left = self.unary()
        while self.at < len(self.tokens):
            operator = self.tokens[self.at]
            level = _BINARY.get(operator) if isinstance(operator, str) else None
            if level is None or level <= loosest:
                break
            self.at += 1
            left = ("binary", operator, left, self.expression(level))
        return left

    def unary(self):
        if self.at >= len(self.tokens):
            raise ShaderError("the condition ends early")
        token = self.tokens[self.at]
        self.at += 1
        if isinstance(token, int):
            return ("number", token)
        if token in ("!", "~", "-", "+"):
            return ("unary", token, self.unary())
        if token == "(":
            inner = self.expression(0)
            if self.at >= len(self.tokens) or self.tokens[self.at] != ")":
                raise ShaderError("a '(' is not closed")
            self.at += 1
            return inner
        if _is_name(token):
            return ("name", token)
        raise ShaderError(f"unexpected {token!r}")


def _value(tree, condition: str) -> int:
    kind = tree[0]
    if kind == "number":
        return tree[1]
    if kind == "name":
        raise ShaderError(f"{tree[1]} is not defined (in {condition!r})")
    if kind == "unary":
        x = _value(tree[2], condition)
        return {"!": int(not x), "~": ~x, "-": -x, "+": x}[tree[1]]
    operator, left = tree[1], _value(tree[2], condition)
    if operator == "&&":
        return int(bool(left) and bool(_value(tree[3], condition)))
    if operator == "||":
        return int(bool(left) or bool(_value(tree[3], condition)))
    right = _value(tree[3], condition)
    if operator in ("/", "%"):
        if right == 0:
            raise ShaderError(f"division by zero in {condition!r}")
        quotient = abs(left) // abs(right) * (1 if (left < 0) == (right < 0) else -1)
        return quotient if operator == "/" else left - quotient * right  # C truncates
    return {"*": left * right, "+": left + right, "-": left - right, "<<": left << right,
            ">>": left >> right, "<": int(left < right), ">": int(left > right),
            "<=": int(left <= right), ">=": int(left >= right), "==": int(left == right),
            "!=": int(left != right), "&": left & right, "^": left ^ right,
            "|": left | right}[operator]
