"""One name per measured datum, the same in every table, message and file.

A natural frequency is named by its declared model ``mode`` (`vibupdate.data.pairing`), with
its measured position where that differs: ``"mode 3 (measured 1)"``; an antiresonance by its
receptance and declared ``index``: ``"zero 4 of h_y1,y1"``. The columns of a file take a form
without blanks or commas after the configuration's name (``"A:mode3_hz"``,
``"A:zero4_h_y1/y1_hz"``): docs/outputs.md, "The columns of samples.csv". `vibupdate extract`
names what it finds with the same functions.
"""

from __future__ import annotations

from collections.abc import Mapping


def receptance_name(response: str, excitation: str) -> str:
    """``"h_y1,y3"``: the receptance of ``response`` to a force at ``excitation``."""
    return f"h_{response},{excitation}"


def mode_name(mode: int, measured: int | None = None) -> str:
    """``"mode 3"``, or ``"mode 3 (measured 1)"`` where the measured position differs.

    Parameters
    ----------
    mode : int
        The model mode (1-based, flexible modes only).
    measured : int, optional
        The position (1-based) of the measured frequency in its configuration.
    """
    if measured is None or measured == mode:
        return f"mode {mode}"
    return f"mode {mode} (measured {measured})"


def zero_name(response: str, excitation: str, index: int | None) -> str:
    """``"zero 4 of h_y1,y1"``: zero ``index`` (1-based, from the lowest) of the receptance;
    ``"a zero of h_y1,y1"`` before an index is declared."""
    where = receptance_name(response, excitation)
    return f"a zero of {where}" if index is None else f"zero {index} of {where}"


def mode_column(configuration: str, mode: int, quantity: str = "hz") -> str:
    """``"A:mode3_hz"``: the column of model mode ``mode``'s natural frequency (Hz) in
    ``configuration``; ``quantity="xi"`` for its damping ratio (``"A:mode3_xi"``)."""
    return f"{configuration}:mode{mode}_{quantity}"


def zero_column(configuration: str, response: str, excitation: str, index: int) -> str:
    """``"A:zero4_h_y1/y1_hz"``: the column of zero ``index`` of ``h_<response>,<excitation>``
    (Hz) in ``configuration``."""
    return f"{configuration}:zero{index}_h_{response}/{excitation}_hz"


def frequency_name(row: Mapping) -> str:
    """The name of one row of the ``frequencies`` table of ``results.json`` (a mapping with
    ``kind``, ``index``, ``model_index`` and, for an antiresonance, ``receptance``)."""
    if row["kind"] == "natural":
        return mode_name(row["model_index"], row["index"])
    return f"zero {row['model_index']} of {row['receptance']}"
