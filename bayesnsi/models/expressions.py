"""Safe parser for candidate-term expressions (docs/method.md §1 and 9).

Grammar (whitespace ignored)::

    expr   := term (("+" | "-") term)*
    term   := unary (("*" | "/") unary)*
    unary  := ("+" | "-") unary | power
    power  := atom ("**" unary)?
    atom   := NUMBER | "x" INT | "v" INT | FUNC "(" expr ")" | "(" expr ")"
    FUNC   := "abs" | "sign" | "tanh"

``x<k>`` is the displacement and ``v<k>`` the velocity of DOF ``k`` (numbered from 1).
Exponents must be constants with magnitude at most :data:`MAX_EXPONENT`. Nothing is ever passed
to ``eval``: the text is tokenised, parsed by recursive descent into a small tree and compiled
into a closure over numpy functions.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..exceptions import ExpressionError, ShapeError

__all__ = ["Expression", "parse_expression", "MAX_EXPONENT", "MAX_LENGTH", "MAX_DOF"]

MAX_EXPONENT = 16.0
"""Largest allowed magnitude of a constant exponent."""
MAX_LENGTH = 400
"""Longest accepted expression text, in characters."""
MAX_DOF = 100_000
"""Largest DOF number an expression may read (far beyond any model this package identifies)."""
_MAX_DEPTH = 40

_FUNCTIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "abs": np.abs,
    "sign": np.sign,
    "tanh": np.tanh,
}
_TOKEN = re.compile(
    r"\s*(?:"
    r"(?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    r"|(?P<state>[xv])(?P<dof>\d+)(?![A-Za-z_0-9])"
    r"|(?P<name>[A-Za-z_][A-Za-z_0-9]*)"
    r"|(?P<op>\*\*|[-+*/()])"
    r")",
    re.ASCII,  # digits and names in ASCII only: x١**3 (an Arabic-Indic one) is refused
)
_HELP = (
    "allowed: x<k>, v<k> (k >= 1), numbers, + - * / **, abs(), sign(), tanh(), parentheses; "
    "example: 'v1*abs(v1)' or '(x3-x4)**3'"
)


@dataclass(frozen=True)
class _Node:
    kind: str  # "num", "x", "v", "neg", "bin", "func"
    value: float | int | str = 0
    args: tuple[_Node, ...] = ()


@dataclass(frozen=True)
class Expression:
    """A parsed, validated term expression n(x, v).

    Attributes
    ----------
    text : str
        The expression as written by the user.
    canonical : str
        A normalised spelling (whitespace removed), used as the term's name.
    displacement_dofs, velocity_dofs : tuple of int
        DOFs (1-based) whose displacement / velocity the expression reads.
    """

    text: str
    canonical: str
    displacement_dofs: tuple[int, ...]
    velocity_dofs: tuple[int, ...]
    _tree: _Node = field(repr=False, compare=False)
    _function: Callable = field(repr=False, compare=False)

    @property
    def dofs(self) -> tuple[int, ...]:
        """All DOFs read by the expression, sorted."""
        return tuple(sorted(set(self.displacement_dofs) | set(self.velocity_dofs)))

    @property
    def is_constant(self) -> bool:
        """True for a bare number: a constant force (offset) whose coefficient is its size."""
        return not self.dofs

    @property
    def uses_velocity(self) -> bool:
        """True when the expression reads any velocity."""
        return bool(self.velocity_dofs)

    @property
    def switches_with_velocity(self) -> bool:
        """True when a ``sign()`` reads a velocity: the force jumps at velocity reversals
        (friction-like terms), between samples of the data (docs/method.md §10: such terms need the
        interval-mean input and, for accurate coefficients, an upsampled identification grid)."""
        return _sign_of_velocity(self._tree)

    @property
    def is_coulomb(self) -> bool:
        """True when the expression is a sign() of velocities alone: Coulomb friction, a force of constant
        magnitude that jumps at every velocity reversal (not a position-dependent friction sign(v)·g(x))."""
        node = self._tree
        return node.kind == "func" and node.value == "sign" and bool(self.velocity_dofs) and not self.displacement_dofs

    def evaluate(self, x, v):
        """Evaluate n(x, v).

        Parameters
        ----------
        x, v : array_like, shape (n_dofs, ...), or mapping {k-1: array}
            DOF-major displacements [m] and velocities [m/s]: ``x[k-1]`` is DOF ``k``. Any
            trailing shape (samples, batch) is broadcast. A mapping holding only the DOFs the
            expression reads avoids building full arrays for long records.

        Returns
        -------
        numpy.ndarray
            The basis function, with the trailing shape of ``x``.
        """
        try:
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                out = self._function(x, v)
        except (IndexError, KeyError) as err:
            raise ShapeError(
                f"expression {self.canonical!r} reads DOFs {list(self.dofs)}, which x or v does not hold "
                f"({err}); pass arrays with a row per DOF (row k-1 is DOF k) or a mapping with those DOFs"
            ) from None
        if isinstance(x, dict):
            arrays = [*x.values(), *v.values()]
            shape = np.shape(arrays[0]) if arrays else ()  # a constant with no state given: a scalar
        else:
            shape = np.shape(x)[1:]
        return np.broadcast_to(np.asarray(out, dtype=float), shape).copy()

    @property
    def function(self) -> Callable:
        """The compiled closure ``f(x, v)`` without error-state handling or copying.

        For hot loops (time-stepping); may return a scalar or a view and may warn on invalid
        arithmetic. Prefer :meth:`evaluate` elsewhere.
        """
        return self._function

    def __str__(self) -> str:
        return self.canonical

    def __reduce__(self):
        """Pickle by text: the compiled closure is rebuilt by parsing (worker processes)."""
        return (parse_expression, (self.text,))


def parse_expression(text: str) -> Expression:
    """Parse a term expression safely (docs/method.md §9).

    Parameters
    ----------
    text : str
        For example ``"v1*abs(v1)"``, ``"x13**3"`` or ``"sign(v1)*(-1373*x1**2 + 74.6*x1)"``.

    Returns
    -------
    Expression

    Raises
    ------
    ExpressionError
        On any character, name, construct or exponent outside the grammar.
    """
    if not isinstance(text, str):
        raise ExpressionError(f"a term expression must be a string, got {type(text).__name__}; {_HELP}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"expression is {len(text)} characters long, at most {MAX_LENGTH} allowed")
    if not text.strip():
        raise ExpressionError(f"empty term expression; {_HELP}")
    foreign = next((c for c in text if not c.isascii() and (c.isdigit() or c.isnumeric())), None)
    if foreign is not None:
        raise ExpressionError(
            f"expression {text!r} holds the digit {foreign!r} (U+{ord(foreign):04X}), not one of 0-9; write DOFs and "
            "numbers with ASCII digits"
        )
    parser = _Parser(text)
    tree = parser.parse()
    xs: set[int] = set()
    vs: set[int] = set()
    _collect(tree, xs, vs)
    if not xs and not vs and not (tree.kind == "num" and float(tree.value) != 0.0):
        # a bare non-zero number is a constant force basis (an offset, e.g. "1"); anything else is a mistake
        raise ExpressionError(f"expression {text!r} reads no displacement or velocity; {_HELP}")
    return Expression(
        text=text,
        canonical=_render(tree),
        displacement_dofs=tuple(sorted(xs)),
        velocity_dofs=tuple(sorted(vs)),
        _tree=tree,
        _function=_compile(tree),
    )


class _Parser:
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
                raise ExpressionError(f"unexpected character {bad!r} in {text!r}; {_HELP}")
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
                if name not in _FUNCTIONS:
                    raise ExpressionError(f"unknown name {name!r} in {text!r}; {_HELP}")
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
            raise ExpressionError(f"expected {want!r} but found {found} in {self.text!r}; {_HELP}")
        self.pos += 1
        return tok

    def parse(self):
        node = self.expr()
        if self.peek()[0] != "end":
            raise ExpressionError(f"unexpected {self.peek()[1]!r} in {self.text!r}; {_HELP}")
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
            node = _Node("bin", op, (node, self.term()))
        self.depth -= 1
        return node

    def term(self):
        node = self.unary()
        while self.peek() in (("op", "*"), ("op", "/")):
            op = self.take()[1]
            node = _Node("bin", op, (node, self.unary()))
        return node

    def unary(self):
        self._enter()
        tok = self.peek()
        if tok == ("op", "-"):
            self.take()
            node = _Node("neg", 0, (self.unary(),))
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
            return _Node("bin", "**", (base, _Node("num", value)))
        return base

    def atom(self):
        kind, value = self.peek()
        if kind == "num":
            self.take()
            return _Node("num", value)
        if kind in ("x", "v"):
            self.take()
            return _Node(kind, value)
        if kind == "func":
            self.take()
            self.take("op", "(")
            arg = self.expr()
            self.take("op", ")")
            return _Node("func", value, (arg,))
        if (kind, value) == ("op", "("):
            self.take()
            node = self.expr()
            self.take("op", ")")
            return node
        found = "end of expression" if kind == "end" else repr(value)
        raise ExpressionError(f"expected a number, x<k>, v<k>, function or '(' but found {found} in {self.text!r}")


def _constant_value(node: _Node):
    if node.kind == "num":
        return float(node.value)
    if node.kind == "neg":
        inner = _constant_value(node.args[0])
        return None if inner is None else -inner
    return None


def _collect(node: _Node, xs: set, vs: set) -> None:
    if node.kind == "x":
        xs.add(node.value)
    elif node.kind == "v":
        vs.add(node.value)
    for arg in node.args:
        _collect(arg, xs, vs)


def _sign_of_velocity(node: _Node) -> bool:
    if node.kind == "func" and node.value == "sign":
        xs: set[int] = set()
        vs: set[int] = set()
        _collect(node.args[0], xs, vs)
        if vs:
            return True
    return any(_sign_of_velocity(arg) for arg in node.args)


def _render(node: _Node) -> str:
    if node.kind == "num":
        return f"{node.value:g}"
    if node.kind in ("x", "v"):
        return f"{node.kind}{node.value}"
    if node.kind == "neg":
        return f"-({_render(node.args[0])})" if node.args[0].kind == "bin" else f"-{_render(node.args[0])}"
    if node.kind == "func":
        return f"{node.value}({_render(node.args[0])})"
    left, right = (_render(a) for a in node.args)
    if node.args[0].kind == "bin" and str(node.value) in "*/**":
        left = f"({left})"
    if node.args[1].kind == "bin" or (str(node.value) in "-/" and node.args[1].kind == "neg"):
        right = f"({right})"
    return f"{left}{node.value}{right}"


_BINARY = {
    "+": np.add,
    "-": np.subtract,
    "*": np.multiply,
    "/": np.divide,
}


def _small_power(a: np.ndarray, p: int):
    """``a ** p`` for p in 0..4 by multiplication."""
    if p == 0:
        return np.ones_like(a)
    if p == 1:
        return a.copy()  # never a view of the caller's data
    square = a * a
    return square if p == 2 else square * a if p == 3 else square * square


def _compile(node: _Node) -> Callable:
    kind = node.kind
    if kind == "num":
        c = float(node.value)
        return lambda x, v: c
    if kind == "x":
        k = int(node.value) - 1
        return lambda x, v: x[k]
    if kind == "v":
        k = int(node.value) - 1
        return lambda x, v: v[k]
    if kind == "neg":
        f = _compile(node.args[0])
        return lambda x, v: -f(x, v)
    if kind == "func":
        fn, f = _FUNCTIONS[str(node.value)], _compile(node.args[0])
        return lambda x, v: fn(f(x, v))
    f, g = (_compile(a) for a in node.args)
    if node.value == "**":
        p = float(node.args[1].value)
        if p == int(p) and 0 <= p <= 4:  # products: numpy's float ** 3 calls pow(), ~20x slower
            ip = int(p)
            return lambda x, v: _small_power(np.asarray(f(x, v), dtype=float), ip)
        if p == int(p) and p >= 0:
            ip = int(p)
            return lambda x, v: np.asarray(f(x, v), dtype=float) ** ip
        return lambda x, v: np.power(np.asarray(f(x, v), dtype=float), p)
    op = _BINARY[str(node.value)]
    return lambda x, v: op(f(x, v), g(x, v))
