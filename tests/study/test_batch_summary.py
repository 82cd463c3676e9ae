"""The summary table of a batch (`vibupdate.study.batch.summary_markdown`)."""

from vibupdate.study.batch import summary_markdown


def test_a_message_with_a_line_break_and_a_bar_stays_one_row_and_a_missing_figure_reads_dash():
    rows = [{"case": "a", "status": "bad_input", "objective": None, "message": "line 1\nline 2 | more"},
            {"case": "b", "status": "success", "objective": 1.234567891, "message": ""}]
    lines = summary_markdown(rows, ["case", "status", "objective", "message"]).splitlines()
    assert len(lines) == 4                              # header, rule and one line per case
    assert lines[2] == "| a | bad_input | - | line 1 line 2 / more |"
    assert lines[3] == "| b | success | 1.23457 | - |"
