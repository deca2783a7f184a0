"""``order = "auto"`` says when a later gap of the singular values is nearly as large as the one it chose.

On a swept-sine beam measured by accelerometers (modes 30, 120, 300 Hz) "auto" takes order 2 (the first
mode dominates the integrated displacement: gaps 1.99 after order 2, 1.32 after 4, 1.77 after 14); the
note says that a later gap is nearly as large, so the model may lack modes. Reference singular values are built
from the gaps they must have; the paper's two-DOF case must stay silent (its order 4 is right).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bayesnsi.exceptions import OrderWarning
from bayesnsi.nsi import identify
from bayesnsi.nsi.order import auto_order, order_note, select_order
from bayesnsi.options import NSIOptions
from bayesnsi.simulate import simulate_case


def _singular_values(gaps_after: dict[int, float], n: int = 40) -> np.ndarray:
    gaps = np.full(n - 1, 0.02)
    for order, gap in gaps_after.items():
        gaps[order - 1] = gap
    return np.exp(-np.concatenate([[0.0], np.cumsum(gaps)]))


def test_a_later_gap_nearly_as_large_is_named():
    s = _singular_values({2: 1.99, 4: 1.32, 14: 1.77, 9: 1.9})  # odd orders are not structural: not named
    assert select_order(s, 38) == 2
    note = order_note(s, 2, 38)
    assert note is not None and "4 (0.66x), 14 (0.89x)" in note and "9 (" not in note
    with pytest.warns(OrderWarning, match=r'order "auto" took 2'):
        assert auto_order(s, 38) == 2
    assert order_note(_singular_values({2: 1.7, 4: 2.5, 8: 1.0}), 4, 38) is None  # later gaps below half
    # "auto" takes max_order (40) when no gap stands out: said too
    assert "the largest order it considers" in order_note(_singular_values({40: 0.3}, n=60), 40, 40)


def test_the_two_dof_case_chooses_its_order_without_a_word():
    case = simulate_case("two-dof", seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", OrderWarning)
        result = identify(case.signals, case.candidates[0], case.recommended.replace(order="auto"))
    assert result.order == 4 and isinstance(case.recommended, NSIOptions)


def test_identify_prints_the_order_note_as_select_does(tmp_path, capsys, monkeypatch):
    # identify recorded the note in results.json only; it now prints it as select does, a line per candidate
    from bayesnsi.cli import main
    from bayesnsi.nsi import order as order_module

    monkeypatch.setattr(order_module, "order_note", lambda s, order, max_order, even=True: (
        f'{order_module.ORDER_NOTE_START} {order}, at the largest gap of the singular values, but ...'))
    csv = tmp_path / "d.csv"
    assert main(["simulate", "two-dof", "--seed", "1", "--out", str(csv), "--quiet"]) == 0
    config = csv.with_suffix(".toml")
    config.write_text(config.read_text().replace("order = 4", 'order = "auto"'))
    capsys.readouterr()
    assert main(["identify", str(config), "--out", str(tmp_path / "id"), "--quiet", "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert "warning: 'model 1': order \"auto\" took 4" in err and "'model 3': order" in err
