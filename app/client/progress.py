"""A progress bar for ``wait``: a widget in Jupyter (tqdm.notebook, when ipywidgets is
installed), text in a terminal or a notebook without widgets (tqdm), nothing when off."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator

Show = Callable[[int, int, str], None]


def _tqdm():
    try:
        from IPython import get_ipython

        in_notebook = get_ipython() is not None and "IPKernelApp" in get_ipython().config
    except ImportError:
        in_notebook = False
    if in_notebook:
        try:
            import ipywidgets  # noqa: F401  (tqdm.notebook draws with it)
            from tqdm.notebook import tqdm

            return tqdm
        except ImportError:
            pass
    from tqdm import tqdm

    return tqdm


@contextlib.contextmanager
def bar(enabled: bool, label: str) -> Iterator[Show]:
    """Yields ``show(done, total, text)``; the bar closes on exit."""
    if not enabled:
        yield lambda done, total, text: None
        return
    t = _tqdm()(desc=label, total=None, unit="", dynamic_ncols=True)

    def show(done: int, total: int, text: str) -> None:
        if total and t.total != total:
            t.total = total
        t.n = done
        t.set_postfix_str(text.strip()[:60], refresh=False)
        t.refresh()

    try:
        yield show
    finally:
        t.close()
