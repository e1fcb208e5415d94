#!/usr/bin/env python3
"""Renders the figures of `kfx reproduce --out DIR` from the CSV files it writes (PNG and SVG).

Usage: python3 python/kfx_figures.py DIR [DIR ...]

Kept for existing scripts: the renderers live in python/kfx/plots.py (kfx.plots), which needs only
matplotlib (Debian: python3-matplotlib). `kfx reproduce --out DIR` runs them itself.
"""
import os
import runpy
import sys

if __name__ == "__main__":
    sys.argv[0] = os.path.join(os.path.dirname(os.path.abspath(__file__)), "kfx", "plots.py")
    runpy.run_path(sys.argv[0], run_name="__main__")
