"""Read-only access to one run's output: results.h5, summary.json and the resolved case."""
import json
import math
import os

import h5py
import numpy as np

try:
    import tomllib
except ImportError:  # Python < 3.11
    tomllib = None


class ReportError(Exception):
    """A problem the user can fix (missing files, unreadable output); printed as one line."""


def _text(value):
    """HDF5 string attribute or dataset (bytes, numpy bytes, str, 0-d or 1-element array) -> str."""
    if isinstance(value, np.ndarray):
        value = value.item() if value.size == 1 else value.tolist()
    if isinstance(value, (bytes, np.bytes_)):
        return value.decode("utf-8", "replace")
    return str(value) if not isinstance(value, str) else value


def parse_toml_value(text):
    """One TOML value as written in /parameters (e.g. '0.5', '"power"', '[0.0, 0.0, 0.0]', 'true')."""
    if tomllib is not None:
        try:
            return tomllib.loads("v = " + text)["v"]
        except Exception:
            pass
    t = text.strip()
    if t in ("true", "false"):
        return t == "true"
    if t.startswith('"') and t.endswith('"'):
        return t[1:-1]
    if t.startswith("[") and t.endswith("]"):
        return [parse_toml_value(x) for x in t[1:-1].split(",") if x.strip()]
    try:
        return int(t)
    except ValueError:
        pass
    try:
        return float(t)
    except ValueError:
        return t


def locate_output(path):
    """DIR may be an output directory (results.h5 + summary.json) or a case directory (DIR/output)."""
    path = os.path.abspath(path)
    if not os.path.isdir(path):
        raise ReportError(f"{path}: no such directory")
    candidates = [path, os.path.join(path, "output")]
    for c in candidates:
        if os.path.isfile(os.path.join(c, "results.h5")) or os.path.isfile(os.path.join(c, "summary.json")):
            missing = [f for f in ("results.h5", "summary.json") if not os.path.isfile(os.path.join(c, f))]
            if missing:
                raise ReportError(f"{c}: {' and '.join(missing)} missing (was the run interrupted? "
                                  f"re-run `grainbath run`)")
            return c
    if os.path.isfile(os.path.join(path, "case.toml")):
        raise ReportError(f"{path}: no results.h5/summary.json in {os.path.join(path, 'output')} "
                          f"(run `grainbath run {path}` first, or pass the --out directory of the run)")
    raise ReportError(f"{path}: no results.h5 and summary.json here or in {os.path.join(path, 'output')} "
                      f"(pass a case directory or a run's output directory)")


class RunData:
    """One run. `run.h5` is the open h5py.File; `run.summary` the parsed summary.json."""

    def __init__(self, out_dir):
        self.out_dir = out_dir
        try:
            with open(os.path.join(out_dir, "summary.json")) as f:
                self.summary = json.load(f)
        except (OSError, ValueError) as e:
            raise ReportError(f"{out_dir}/summary.json: cannot read it ({e})")
        try:
            self.h5 = h5py.File(os.path.join(out_dir, "results.h5"), "r")
        except OSError as e:
            raise ReportError(f"{out_dir}/results.h5: cannot open it as HDF5 ({e})")
        self.solver = self.root_attr("solver") or self.summary.get("solver") or "unknown"
        self.params = {}
        if "parameters" in self.h5:
            for k, v in self.h5["parameters"].attrs.items():
                self.params[k] = parse_toml_value(_text(v))

    def close(self):
        self.h5.close()

    # ---- HDF5 ---------------------------------------------------------------------------
    def has(self, *paths):
        """True when every dataset/group path exists."""
        return all(p in self.h5 for p in paths)

    def arr(self, path):
        """Dataset as a float numpy array (None when absent)."""
        if path not in self.h5:
            return None
        return np.asarray(self.h5[path][()], dtype=float)

    def text(self, path):
        if path not in self.h5:
            return None
        return _text(self.h5[path][()])

    def root_attr(self, name):
        return _text(self.h5.attrs[name]) if name in self.h5.attrs else None

    def attr(self, path, name, default=None):
        if path not in self.h5 or name not in self.h5[path].attrs:
            return default
        v = self.h5[path].attrs[name]
        if isinstance(v, (bytes, np.bytes_, str)):
            return _text(v)
        v = np.asarray(v)
        return v.item() if v.size == 1 else v

    # ---- summary.json -------------------------------------------------------------------
    def get(self, key, default=None):
        """summary value by dotted key ('theory.equilibrium.sonine.T'); default when absent."""
        node = self.summary
        for part in key.split("."):
            if not isinstance(node, dict) or part not in node:
                return default
            node = node[part]
        return node

    def num(self, key):
        """summary number by dotted key, or None when absent / not finite."""
        v = self.get(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            return None
        return float(v) if math.isfinite(v) else None

    def flat_summary(self):
        """[(dotted key, value)] for every leaf of summary.json, in file order."""
        out = []

        def walk(prefix, node):
            if isinstance(node, dict):
                for k, v in node.items():
                    walk(f"{prefix}.{k}" if prefix else k, v)
            else:
                out.append((prefix, node))

        walk("", self.summary)
        return out

    # ---- parameters ---------------------------------------------------------------------
    def param(self, key, default=None):
        return self.params.get(key, default)

    def vec3(self, key, default=(0.0, 0.0, 0.0)):
        v = self.params.get(key)
        if isinstance(v, list) and len(v) == 3:
            return np.asarray(v, dtype=float)
        return np.asarray(default, dtype=float)
