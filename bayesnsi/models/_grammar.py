"""The text of a term expression: tokens, recursive-descent parse tree and canonical spelling.

The grammar is documented in :mod:`bayesnsi.models.expressions`, which compiles the tree into numpy
closures; nothing here evaluates anything.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..exceptions import ExpressionError
from .hysteresis import BoucWen

MAX_EXPONENT = 16.0
"""Largest allowed magnitude of a constant exponent."""
MAX_DOF = 100_000
"""Largest DOF number an expression may read (far beyond any model this package identifies)."""
_MAX_DEPTH = 40

FUNCTION_NAMES = ("abs", "sign", "tanh")
MEMORY = "boucwen"
"""Name of the Bouc-Wen hysteretic variable in the grammar (a term of its own, module notes)."""
_KEYWORDS = ("beta", "gamma", "n")
_TOKEN = re.compile(
    r"\s*(?:"
    r"(?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    r"|(?P<state>[xv])(?P<dof>\d+)(?![A-Za-z_0-9])"
    r"|(?P<name>[A-Za-z_][A-Za-z_0-9]*)"
    r"|(?P<op>\*\*|[-+*/()=,])"
    r")",
    re.ASCII,  # digits and names in ASCII only: x١**3 (an Arabic-Indic one) is refused
)
HELP = (
    "allowed: x<k>, v<k> (k >= 1), numbers, + - * / **, abs(), sign(), tanh(), parentheses; "
    "example: 'v1*abs(v1)' or '(x3-x4)**3'; or a Bouc-Wen term alone, 'boucwen(x1, beta=800, gamma=-1100)'"
)


@dataclass(frozen=True)
class Node:
    kind: str  # "num", "x", "v", "neg", "bin", "func", "memory"
    value: float | int | str = 0
    args: tuple[Node, ...] = ()
    shape: BoucWen | None = None  # of a "memory" node


class Parser:
    def __init__(self, text: str):
        self.text = text
        self.tokens = self._tokenise(text)
        self.pos = 0
        self.depth = 0

    def _tokenise(self, text):
        tokens, pos = [], 0
        while pos < len(text):
            if text[pos:].strip() == "":
                break
            m = _TOKEN.match(text, pos)
            if m is None or m.end() == pos:
                bad = text[pos:].lstrip()[:1]
                raise ExpressionError(f"unexpected character {bad!r} in {text!r}; {HELP}")
            if m.group("number"):
                tokens.append(("num", float(m.group("number"))))
            elif m.group("state"):
                dof = int(m.group("dof"))
                if dof > MAX_DOF:
                    raise ExpressionError(f"DOF {dof} in {self.text!r} is beyond {MAX_DOF}; DOFs are numbered from 1")
                if dof < 1:
                    raise ExpressionError(f"DOFs are numbered from 1, found {m.group(0).strip()!r} in {text!r}")
                tokens.append((m.group("state"), dof))
            elif m.group("name"):
                name = m.group("name")
                if name in _KEYWORDS:
                    tokens.append(("key", name))
                    pos = m.end()
                    continue
                if name not in FUNCTION_NAMES and name != MEMORY:
                    raise ExpressionError(f"unknown name {name!r} in {text!r}; {HELP}")
                tokens.append(("func", name))
            else:
                tokens.append(("op", m.group("op")))
            pos = m.end()
        return tokens

    def peek(self):
        return self.tokens[self.pos] if self.pos < len(self.tokens) else ("end", None)

    def take(self, kind=None, value=None):
        tok = self.peek()
        if (kind and tok[0] != kind) or (value is not None and tok[1] != value):
            want = value if value is not None else kind
            found = "end of expression" if tok[0] == "end" else repr(tok[1])
            raise ExpressionError(f"expected {want!r} but found {found} in {self.text!r}; {HELP}")
        self.pos += 1
        return tok

    def parse(self):
        node = self.expr()
        if self.peek()[0] != "end":
            raise ExpressionError(f"unexpected {self.peek()[1]!r} in {self.text!r}; {HELP}")
        return node

    def _enter(self):
        self.depth += 1
        if self.depth > _MAX_DEPTH:
            raise ExpressionError(f"expression {self.text[:40]!r}... nests deeper than {_MAX_DEPTH} levels")

    def expr(self):
        self._enter()
        node = self.term()
        while self.peek() in (("op", "+"), ("op", "-")):
            op = self.take()[1]
            node = Node("bin", op, (node, self.term()))
        self.depth -= 1
        return node

    def term(self):
        node = self.unary()
        while self.peek() in (("op", "*"), ("op", "/")):
            op = self.take()[1]
            node = Node("bin", op, (node, self.unary()))
        return node

    def unary(self):
        self._enter()
        tok = self.peek()
        if tok == ("op", "-"):
            self.take()
            node = Node("neg", 0, (self.unary(),))
        elif tok == ("op", "+"):
            self.take()
            node = self.unary()
        else:
            node = self.power()
        self.depth -= 1
        return node

    def power(self):
        base = self.atom()
        if self.peek() == ("op", "**"):
            self.take()
            exponent = self.unary()
            value = _constant_value(exponent)
            if value is None:
                raise ExpressionError(f"exponents must be constant numbers in {self.text!r}")
            if not np.isfinite(value) or abs(value) > MAX_EXPONENT:
                raise ExpressionError(
                    f"exponent {value:g} in {self.text!r} is outside [-{MAX_EXPONENT:g}, {MAX_EXPONENT:g}]"
                )
            return Node("bin", "**", (base, Node("num", value)))
        return base

    def atom(self):
        kind, value = self.peek()
        if kind == "num":
            self.take()
            return Node("num", value)
        if kind in ("x", "v"):
            self.take()
            return Node(kind, value)
        if (kind, value) == ("func", MEMORY):
            self.take()
            return self.memory()
        if kind == "func":
            self.take()
            self.take("op", "(")
            arg = self.expr()
            self.take("op", ")")
            return Node("func", value, (arg,))
        if (kind, value) == ("op", "("):
            self.take()
            node = self.expr()
            self.take("op", ")")
            return node
        found = "end of expression" if kind == "end" else repr(value)
        raise ExpressionError(f"expected a number, x<k>, v<k>, function or '(' but found {found} in {self.text!r}")

    def memory(self):
        """``boucwen(DISP, beta=.., gamma=.., [n=..])`` after its name (module grammar)."""
        self.take("op", "(")
        argument = self.expr()
        if not _is_displacement(argument):
            raise ExpressionError(
                f"{MEMORY}() follows a displacement, x<k> or x<j>-x<k> (the law is rate independent: z depends on the "
                f"displacement path), got {render(argument)!r} in {self.text!r}"
            )
        values: dict[str, float] = {}
        while self.peek() == ("op", ","):
            self.take()
            key = self.take("key")[1]
            if key in values:
                raise ExpressionError(f"{MEMORY}() gives {key} twice in {self.text!r}")
            self.take("op", "=")
            number = _constant_value(self.unary())
            if number is None:
                raise ExpressionError(f"{MEMORY}() needs a number for {key} in {self.text!r}")
            values[key] = number
        self.take("op", ")")
        missing = [k for k in ("beta", "gamma") if k not in values]
        if missing:
            raise ExpressionError(
                f"{MEMORY}() needs {' and '.join(missing)} in {self.text!r}, e.g. 'boucwen(x1, beta=800, gamma=-1100)'"
            )
        shape = BoucWen(values["beta"], values["gamma"], values.get("n", 1.0))
        return Node("memory", MEMORY, (argument,), shape)


def _is_displacement(node: Node) -> bool:
    """``x<k>`` or ``x<j> - x<k>`` (j ≠ k): what a Bouc-Wen variable follows."""
    if node.kind == "x":
        return True
    return (node.kind == "bin" and node.value == "-" and all(a.kind == "x" for a in node.args)
            and node.args[0].value != node.args[1].value)


def check_memory(tree: Node, text: str) -> None:
    """A ``boucwen`` variable is a whole expression: its coefficient is the hysteretic stiffness."""
    inner = [a for a in tree.args if _holds_memory(a)]
    if inner or (tree.kind != "memory" and _holds_memory(tree)):
        raise ExpressionError(
            f"{MEMORY}() is a term of its own in {text!r}: write it alone (its coefficient is the hysteretic stiffness)"
        )


def _holds_memory(node: Node) -> bool:
    return node.kind == "memory" or any(_holds_memory(a) for a in node.args)


def _constant_value(node: Node):
    if node.kind == "num":
        return float(node.value)
    if node.kind == "neg":
        inner = _constant_value(node.args[0])
        return None if inner is None else -inner
    return None


def render(node: Node) -> str:
    if node.kind == "num":
        return f"{node.value:g}"
    if node.kind in ("x", "v"):
        return f"{node.kind}{node.value}"
    if node.kind == "neg":
        return f"-({render(node.args[0])})" if node.args[0].kind == "bin" else f"-{render(node.args[0])}"
    if node.kind == "func":
        return f"{node.value}({render(node.args[0])})"
    if node.kind == "memory":
        assert node.shape is not None
        return f"{MEMORY}({render(node.args[0])},{node.shape.text()})"
    left, right = (render(a) for a in node.args)
    if node.args[0].kind == "bin" and str(node.value) in "*/**":
        left = f"({left})"
    if node.args[1].kind == "bin" or (str(node.value) in "-/" and node.args[1].kind == "neg"):
        right = f"({right})"
    return f"{left}{node.value}{right}"


