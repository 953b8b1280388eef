"""ODiSI .tsv exports (documented layout) load into the same Measurements as the equivalent CSV."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torchshm import load_measurements
from torchshm.data.anomaly import anomaly_mask, flag_anomalies
from torchshm.data.measurements import Measurements
from torchshm.data.odisi import parse

# one gauge "G1", then two segments along the fibre: "top" from 1.0 m and "bot" from 3.0 m, 0.5 m pitch
NAMES = ["G1"] + [f"top[{k}]" for k in range(4)] + [f"bot[{k}]" for k in range(3)]
X = [0.25, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]
TARE = [0.0, 1.0, 1.0, 1.0, 1.0, -2.0, -2.0, -2.0]
TIMES = ["2024-05-02 10:00:00.000000", "2024-05-02 10:00:01.000000",  # load 39.8
         "2024-05-02 10:05:00.000000", "2024-05-02 10:05:01.000000"]  # load 47.5
ROWS = np.array([
    [9.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0],
    [9.0, 1.5, 2.5, 3.5, np.nan, 5.5, 6.5, 7.5],
    [9.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0],
    [9.0, 10.5, 20.5, 30.5, 40.5, 50.5, 60.5, 70.5],
])
WINDOWS = {39.8: ("2024-05-02 10:00:00", "2024-05-02 10:00:02"),
           47.5: ("2024-05-02 10:04:59", "2024-05-02 10:05:01")}


def write_tsv(path: Path, rows: np.ndarray = ROWS, times: list[str] = TIMES, gauges: bool = True) -> Path:
    def cells(values) -> str:
        return "\t".join("" if np.isnan(v) else repr(float(v)) for v in values)

    text = ["Test name:\tbridge 705 load test", "Channel:\t1", "Gage Pitch (mm):\t500.0", "Units:\tmicrostrain",
            "-" * 40]
    if gauges:
        text.append("Gage/Segment Name\t\t\t" + "\t".join(NAMES))
    text += ["x-axis\t\t\t" + cells(X), "tare\t\t\t" + cells(TARE)]
    text += [f"{t}\tmeasurement\tstrain\t{cells(r)}" for t, r in zip(times, rows)]
    path.write_text("\n".join(text) + "\n", encoding="utf-8")
    return path


def equivalent_csv(path: Path) -> Path:
    """The same data by hand: window means of the 'top' and 'bot' columns, NaN where lost."""
    means = {39.8: (ROWS[0] + ROWS[1]) / 2, 47.5: (ROWS[2] + ROWS[3]) / 2}
    means[39.8][4] = 4.0  # the lost reading of row 2 leaves row 1's alone
    lines = ["# missing=mask", "line,load,x,strain"]
    for load, mean in means.items():
        lines += [f"top,{load},{X[c]},{float(mean[c])!r}" for c in range(1, 5)]
        lines += [f"bot,{load},{X[c]},{float(mean[c])!r}" for c in range(5, 8)]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_odisi_equals_the_equivalent_csv(tmp_path: Path) -> None:
    tsv = write_tsv(tmp_path / "run.tsv")
    m = load_measurements(tsv, lines={"top": "top", "bot": "bot"}, windows=WINDOWS, missing="mask")
    csv = load_measurements(equivalent_csv(tmp_path / "run.csv"))
    assert m.equals(csv), (m.y, csv.y)
    assert m.lines == ("top", "bot") and m.n_missing == 0
    f = parse(tsv)
    assert f.metadata["Units"] == "microstrain" and f.names == NAMES and len(f.times) == 4


def test_one_file_per_load_case_tare_reference_and_ranges(tmp_path: Path) -> None:
    a = write_tsv(tmp_path / "a.tsv", ROWS[:2], TIMES[:2], gauges=False)
    b = write_tsv(tmp_path / "b.tsv", ROWS[2:], TIMES[2:], gauges=False)
    m = load_measurements({39.8: a, 47.5: b}, format="odisi", lines={"top": (1.0, 2.5)}, missing="mask")
    np.testing.assert_array_equal(m.y[1], (ROWS[2, 1:5] + ROWS[3, 1:5]) / 2)
    added = load_measurements({39.8: a}, format="odisi", lines={"top": (1.0, 2.5)}, tare="add", missing="mask")
    np.testing.assert_array_equal(added.y[0], np.array([1.25, 2.25, 3.25, 4.0]) + 1.0)
    whole = load_measurements(write_tsv(tmp_path / "c.tsv", gauges=False), windows={47.5: WINDOWS[47.5]},
                              reference=WINDOWS[39.8], lines={"top": (1.0, 2.5)})
    np.testing.assert_array_equal(whole.y[0], [9.0, 18.0, 27.0, 36.25])  # 40.25 - 4.0 (lost cell ignored)
    lost = ROWS[:2].copy()
    lost[:, 6] = np.nan  # lost in every row of the load case
    d = write_tsv(tmp_path / "d.tsv", lost, TIMES[:2], gauges=False)
    with pytest.raises(ValueError, match=r"1 NaN or inf value\(s\), first at load 39.8, x = 3.5 m .*missing='mask'"):
        load_measurements({39.8: d}, format="odisi")
    assert load_measurements({39.8: d}, format="odisi", missing="mask").n_missing == 1


@pytest.mark.parametrize("spoil, fragment", [
    (lambda t: t.replace("-" * 40 + "\n", ""), r"no '----' line ending the metadata block"),
    (lambda t: t.replace("x-axis", "x-axes"), r"line 7: expected the 'x-axis' row"),
    (lambda t: t.replace("\t2.0\t3.0", "\tabc\t3.0"), r"line 9, column 6 \(top\[1\]\): 'abc' is not a number"),
    (lambda t: t.replace("2024-05-02 10:05:00.000000", "yesterday"), r"line 11: 'yesterday' is not a date"),
    (lambda t: t.replace("\t70.5", ""), r"line 12: 7 values, expected 8 as in the x-axis row"),
])
def test_malformed_export_names_the_row(tmp_path: Path, spoil, fragment: str) -> None:
    path = write_tsv(tmp_path / "run.tsv")
    path.write_text(spoil(path.read_text()))
    with pytest.raises(ValueError, match=fragment) as info:
        load_measurements(path, lines={"top": "top"}, windows=WINDOWS)
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def test_bad_options_are_named(tmp_path: Path) -> None:
    tsv = write_tsv(tmp_path / "run.tsv")
    with pytest.raises(ValueError, match="no segment or gauge 'side'"):
        load_measurements(tsv, lines={"s": "side"}, windows=WINDOWS)
    with pytest.raises(ValueError, match="no time-stamped row within the window of load 60"):
        load_measurements(tsv, lines={"t": "top"}, windows={60: ("2024-05-03 00:00:00", "2024-05-03 00:01:00")})
    with pytest.raises(ValueError, match="name the load cases"):
        load_measurements(tsv, lines={"t": "top"})
    with pytest.raises(TypeError, match="format='odisi' only"):
        load_measurements(tmp_path / "x.csv", windows=WINDOWS)


def test_anomaly_rule_flags_spikes_not_steps() -> None:
    step = np.r_[np.zeros(10), np.full(10, 50.0)]
    assert not anomaly_mask(step, threshold=20.0).any()  # a real change over many gauges
    spike = step.copy()
    spike[4] = 80.0
    spike[15] = np.nan
    np.testing.assert_array_equal(np.flatnonzero(anomaly_mask(spike, threshold=20.0)), [4])
    m = Measurements(np.arange(20) * 0.1, np.vstack([spike, step]), [1.0, 2.0], missing="mask")
    flagged = flag_anomalies(m, threshold=20.0)
    assert flagged.n_missing == 2 and not flagged.mask[0, 4]
    with pytest.raises(ValueError, match="threshold must be a positive"):
        anomaly_mask(spike, threshold=0.0)


def test_anomaly_option_of_the_reader(tmp_path: Path) -> None:
    rows = ROWS.copy()
    rows[0, 2] = rows[1, 2] = 500.0  # a spike on top[1] in both rows of load 39.8
    tsv = write_tsv(tmp_path / "run.tsv", rows)
    m = load_measurements(tsv, lines={"top": "top", "bot": "bot"}, windows=WINDOWS, anomaly=100.0, missing="mask")
    assert m.n_missing == 1 and not m.mask[0, 1]
