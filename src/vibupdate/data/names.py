"""One name per measured datum, the same in every table, message and file.

* A natural frequency is named by the model mode it is compared with (its declared ``mode``,
  `vibupdate.data.pairing`): ``"mode 3"``. Where that differs from its position among the
  measured frequencies of its configuration (a test whose first measured mode is the model's
  third), the position follows: ``"mode 3 (measured 1)"``.
* An antiresonance is named by its receptance and the zero of that receptance it is compared
  with (its declared ``index``): ``"zero 4 of h_y1,y1"``. Its position in the configuration's
  list mixes receptances and is never shown.
* A receptance is ``"h_<response>,<excitation>"``.

In the columns of a file (a sweep's ``samples.csv``, the labels of its ``sweep.json``) the same
names take a form without blanks or commas, after the configuration's name: ``"A:mode3_hz"``
(the natural frequency of model mode 3, Hz), ``"A:mode3_xi"`` (its damping ratio),
``"A:zero4_h_y1/y1_hz"`` (zero 4 of ``h_y1,y1``, Hz: response ``/`` excitation, as the
receptance is the response over the force). A column names the model mode alone: the modes of
a configuration are distinct and rising, and a column keeps its name whatever else is measured.

`vibupdate extract` names what it finds with the same functions, so an extracted zero and the
same zero in a run's report read alike.
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
