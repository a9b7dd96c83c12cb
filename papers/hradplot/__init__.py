"""hradplot: paper figures and tables from hrad results stores.

Reads a results store (SQLite file written by `hrad sweep`, or a CSV folder
written by `hrad results export`) and draws figures in one paper style
(vector PDF + PNG, single-column width, Okabe-Ito palette).

    /usr/bin/python3 -m hradplot --help      (run from papers/)
"""
from .store import Store, StoreError, load_store  # noqa: F401
