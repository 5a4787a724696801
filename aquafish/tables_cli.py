"""``aquafish tables``: the README's result tables rendered from the run records they report
(:mod:`aquafish.tables`): print them, write them into a page, or check a page against them."""

from __future__ import annotations

import argparse
from pathlib import Path

from aquafish_gym.argtypes import path

#: Exit status of ``--check`` when a table of the page differs from its records.
EXIT_DIFFERS = 1


def _tables(args: argparse.Namespace) -> int:
    from aquafish.tables import TABLES, check_page, render_page
    from aquafish_gym.files import atomic_write

    page = args.write or args.check
    root = args.root if args.root is not None else (page.parent if page is not None else Path("."))
    if page is None:
        unknown = [n for n in args.names if n not in TABLES]
        if unknown:
            raise ValueError(f"unknown tables {', '.join(unknown)}; known: {', '.join(TABLES)}")
        for i, name in enumerate(args.names or TABLES):
            print(("\n" if i else "") + f"<!-- table: {name} -->\n\n{TABLES[name].table(root)}\n\n<!-- /table -->")
        return 0
    if args.names:
        raise ValueError("table names go without --write or --check, which take every table the page marks")
    text = page.read_text()
    if args.check:
        count, differences = check_page(text, root, source=str(page))
        if not count:
            raise ValueError(f"{page} marks no table (<!-- table: NAME --> ... <!-- /table -->; NAME one of "
                             f"{', '.join(TABLES)})")
        for line in differences:
            print(f"{page}: {line}")
        if differences:
            print(f"{page}: {len(differences)} differences from the records; aquafish tables --write {page} "
                  "renders the tables from them")
            return EXIT_DIFFERS
        print(f"{page}: its {count} tables agree with their records")
        return 0
    new = render_page(text, root, source=str(page))
    if new == text:
        print(f"{page}: its tables already agree with their records (nothing written)")
    else:
        atomic_write(page, new.encode())
        print(f"wrote {page}: its tables rendered from their records")
    return 0


def add_commands(sub) -> None:
    t = sub.add_parser("tables", help="the README's result tables rendered from their run records: print them, "
                                      "--write them into a page or --check a page against them (aquafish.tables)")
    t.add_argument("names", nargs="*", metavar="NAME",
                   help="the tables to print (default: every table of aquafish.tables.TABLES)")
    what = t.add_mutually_exclusive_group()
    what.add_argument("--write", type=path, default=None, metavar="PAGE",
                      help="replace the body of every table PAGE marks (<!-- table: NAME --> ... <!-- /table -->) "
                           "by its rendering, in place")
    what.add_argument("--check", type=path, default=None, metavar="PAGE",
                      help="compare every table PAGE marks with its records: print each cell that differs (table, "
                           "row, column, both texts) and exit with status 1, or one line and status 0")
    t.add_argument("--root", type=path, default=None, metavar="DIR",
                   help="the directory the records' paths are relative to (default: the directory of PAGE, else the "
                        "current directory)")
    t.set_defaults(func=_tables)
