"""readers.py: moreau's output files read into numpy arrays and dicts (pandas DataFrames when asked
and installed): history.csv, summary.json, contact.csv, compare.csv, a whole output folder."""
import csv
import json
import math
import os

import numpy as np


class Table:
    """The columns of a CSV file by name, in the file's order: each a 1-D numpy array, of floats
    when every value of the column is a number (empty cells are NaN), of str otherwise.

    t = read_history("out/ball-bounce"); t["ball.y"], t.columns, len(t) (rows), t.to_pandas()."""

    def __init__(self, columns, path=None):
        self._cols = dict(columns)
        self.path = path

    @property
    def columns(self):
        return list(self._cols)

    def __getitem__(self, name):
        try:
            return self._cols[name]
        except KeyError:
            raise KeyError("%s has no column %r (columns: %s)" % (self.path or "the table", name,
                                                                 ", ".join(self._cols))) from None

    def __contains__(self, name):
        return name in self._cols

    def __iter__(self):
        return iter(self._cols)

    def __len__(self):
        for v in self._cols.values():
            return len(v)
        return 0

    def keys(self):
        return self._cols.keys()

    def items(self):
        return self._cols.items()

    def rows(self, **match):
        """The rows whose columns equal the values given (rows(solver="nscd")), as a Table."""
        keep = np.ones(len(self), dtype=bool)
        for k, v in match.items():
            col = self[k]
            keep &= np.isclose(col, float(v)) if col.dtype.kind == "f" else (col == str(v))
        return Table({k: v[keep] for k, v in self._cols.items()}, self.path)

    def to_numpy(self, columns=None):
        """The numeric columns (or those named) as one 2-D float array, rows by columns."""
        names = columns or [k for k, v in self._cols.items() if v.dtype.kind == "f"]
        return np.column_stack([np.asarray(self[k], dtype=float) for k in names]) if names else np.empty((len(self), 0))

    def to_pandas(self):
        try:
            import pandas
        except ImportError:
            raise ImportError("moreau: pandas is not installed (Debian: apt-get install python3-pandas)") from None
        return pandas.DataFrame(self._cols, columns=self.columns)

    def __repr__(self):
        return "Table(%d rows: %s)" % (len(self), ", ".join(self.columns))


def _number(s):
    if s == "":
        return math.nan
    return float(s)


def _column(values):
    try:
        return np.array([_number(v) for v in values], dtype=float)
    except ValueError:
        return np.array(values, dtype=str)


def _file(path, name):
    """A file given directly, or by its output folder."""
    return os.path.join(path, name) if os.path.isdir(path) else path


def read_csv(path, pandas=False):
    """A CSV file of moreau's (a header line, then rows) as a Table, or a pandas DataFrame."""
    if pandas:
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("moreau: pandas is not installed (Debian: apt-get install python3-pandas)") from None
        return pd.read_csv(path)
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise ValueError("%s: empty (no header line)" % path)
    head, body = rows[0], rows[1:]
    for k, r in enumerate(body):
        if len(r) != len(head):
            raise ValueError("%s:%d: %d values for %d columns" % (path, k + 2, len(r), len(head)))
    return Table({name: _column([r[j] for r in body]) for j, name in enumerate(head)}, path)


def read_history(path, pandas=False):
    """history.csv (a run's folder or the file): column t, then probe.quantity columns."""
    return read_csv(_file(path, "history.csv"), pandas)


def read_contacts(path, pandas=False):
    """contact.csv (a run's folder or the file): per contact candidate of the last step, its pair,
    position, gap, local velocity, reactions and status."""
    return read_csv(_file(path, "contact.csv"), pandas)


def read_compare(path, pandas=False):
    """compare.csv (a comparison's folder or the file): one row per run, solver, dt, the varied
    keys, class, times and every metric."""
    return read_csv(_file(path, "compare.csv"), pandas)


def read_summary(path):
    """summary.json (a run's folder or the file) as a dict."""
    with open(_file(path, "summary.json")) as f:
        return json.load(f)
