"""Safe parser for candidate-term expressions (docs/method.md §1 and 9).

Grammar (whitespace ignored)::

    expr   := term (("+" | "-") term)*
    term   := unary (("*" | "/") unary)*
    unary  := ("+" | "-") unary | power
    power  := atom ("**" unary)?
    atom   := NUMBER | "x" INT | "v" INT | FUNC "(" expr ")" | "(" expr ")"
    FUNC   := "abs" | "sign" | "tanh"

or, as a whole expression, a Bouc-Wen hysteretic variable (:mod:`bayesnsi.models.hysteresis`)::

    memory := "boucwen" "(" DISP "," "beta" "=" NUMBER "," "gamma" "=" NUMBER ["," "n" "=" NUMBER] ")"
    DISP   := "x" INT | "x" INT "-" "x" INT        (parentheses allowed; signed numbers allowed)

``x<k>`` is the displacement and ``v<k>`` the velocity of DOF ``k`` (numbered from 1).
A ``boucwen`` term has memory: its value at a sample depends on the displacement history, so
:meth:`Expression.evaluate` reads axis 0 of the evaluated displacement as time (z = 0 at the first
sample, or the periodic steady state with ``periodic=True``).
Exponents must be constants with magnitude at most :data:`MAX_EXPONENT`. Nothing is ever passed
to ``eval``: the text is tokenised, parsed by recursive descent into a small tree and compiled
into a closure over numpy functions.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..exceptions import ExpressionError, ShapeError
from ._grammar import HELP, MAX_DOF, MAX_EXPONENT, MEMORY, Node, Parser, check_memory, render
from .hysteresis import BoucWen, boucwen_path, boucwen_periodic

__all__ = ["Expression", "parse_expression", "MAX_EXPONENT", "MAX_LENGTH", "MAX_DOF", "MEMORY"]

MAX_LENGTH = 400
"""Longest accepted expression text, in characters."""

_FUNCTIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "abs": np.abs,
    "sign": np.sign,
    "tanh": np.tanh,
}
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
    _tree: Node = field(repr=False, compare=False)
    _function: Callable = field(repr=False, compare=False)
    memory: BoucWen | None = field(default=None, compare=False)
    _argument: Callable | None = field(default=None, repr=False, compare=False)

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

    @property
    def memory_argument(self) -> Callable | None:
        """For a ``boucwen`` term: the compiled closure ``f(x, v)`` of the displacement it follows; else None."""
        return self._argument

    def evaluate(self, x, v, periodic: bool = False):
        """Evaluate n(x, v).

        Parameters
        ----------
        x, v : array_like, shape (n_dofs, ...), or mapping {k-1: array}
            DOF-major displacements [m] and velocities [m/s]: ``x[k-1]`` is DOF ``k``. Any
            trailing shape (samples, batch) is broadcast. A mapping holding only the DOFs the
            expression reads avoids building full arrays for long records. For a ``boucwen``
            term the first trailing axis is time (module notes).
        periodic : bool
            For a ``boucwen`` term: the samples are one period, and z is its periodic steady
            state (:func:`bayesnsi.models.hysteresis.boucwen_periodic`). Ignored otherwise.

        Returns
        -------
        numpy.ndarray
            The basis function, with the trailing shape of ``x``.
        """
        try:
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                if self.memory is not None and self._argument is not None:
                    along = np.asarray(self._argument(x, v), dtype=float)
                    out = boucwen_periodic(self.memory, along) if periodic else boucwen_path(self.memory, along)
                else:
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
        arithmetic. Prefer :meth:`evaluate` elsewhere. A ``boucwen`` term's closure follows axis 0
        as time over a whole record: a time-stepping loop keeps z as a state instead
        (:attr:`memory`, :attr:`memory_argument`, :func:`bayesnsi.models.hysteresis.boucwen_step`).
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
        raise ExpressionError(f"a term expression must be a string, got {type(text).__name__}; {HELP}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"expression is {len(text)} characters long, at most {MAX_LENGTH} allowed")
    if not text.strip():
        raise ExpressionError(f"empty term expression; {HELP}")
    foreign = next((c for c in text if not c.isascii() and (c.isdigit() or c.isnumeric())), None)
    if foreign is not None:
        raise ExpressionError(
            f"expression {text!r} holds the digit {foreign!r} (U+{ord(foreign):04X}), not one of 0-9; write DOFs and "
            "numbers with ASCII digits"
        )
    parser = Parser(text)
    tree = parser.parse()
    check_memory(tree, text)
    xs: set[int] = set()
    vs: set[int] = set()
    _collect(tree, xs, vs)
    if not xs and not vs and not (tree.kind == "num" and float(tree.value) != 0.0):
        # a bare non-zero number is a constant force basis (an offset, e.g. "1"); anything else is a mistake
        raise ExpressionError(f"expression {text!r} reads no displacement or velocity; {HELP}")
    return Expression(
        text=text,
        canonical=render(tree),
        displacement_dofs=tuple(sorted(xs)),
        velocity_dofs=tuple(sorted(vs)),
        _tree=tree,
        _function=_compile(tree),
        memory=tree.shape,
        _argument=_compile(tree.args[0]) if tree.kind == "memory" else None,
    )


def _collect(node: Node, xs: set, vs: set) -> None:
    if node.kind == "x":
        xs.add(node.value)
    elif node.kind == "v":
        vs.add(node.value)
    for arg in node.args:
        _collect(arg, xs, vs)


def _sign_of_velocity(node: Node) -> bool:
    if node.kind == "func" and node.value == "sign":
        xs: set[int] = set()
        vs: set[int] = set()
        _collect(node.args[0], xs, vs)
        if vs:
            return True
    return any(_sign_of_velocity(arg) for arg in node.args)


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


def _compile(node: Node) -> Callable:
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
    if kind == "memory":  # along axis 0 of the displacement it follows, from z = 0 (module notes)
        shape, g = node.shape, _compile(node.args[0])
        return lambda x, v: boucwen_path(shape, np.asarray(g(x, v), dtype=float))  # type: ignore[arg-type]
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
