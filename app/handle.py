"""The inspector opened from Python (skelcore.inspect): a server in background threads and a handle to stop it."""
from __future__ import annotations

from skelcore.errors import InputError
from skelcore.io import Cloud
from skelcore.params import ContractionParams

from .main import LOCAL_HOST, host_problem, serve

IFRAME_HEIGHT = 720  # pixels of the inline view in a notebook


class InspectorHandle:
    """A running inspector. `url` is its address; `stop()` ends the server (also on leaving a `with` block).
    In Jupyter, a cell ending with the handle shows the live inspector inline (an iframe of `url`); `show()`
    does the same from anywhere in a cell, or opens a browser tab outside a notebook."""

    def __init__(self, server, inspector, host: str) -> None:
        self.server, self.inspector = server, inspector
        self.url = f"http://{host}:{server.get_port()}"
        self.stopped = False

    @property
    def session(self):
        """The inspector's app.session.Session: the cloud, the run's states, the weights."""
        return self.inspector.session

    def stop(self) -> None:
        """Stop the inspector's threads and its server (safe to call twice)."""
        if not self.stopped:
            self.stopped = True
            self.inspector.close()
            self.server.stop()

    def show(self, height: int = IFRAME_HEIGHT) -> None:
        """Inline in a notebook, else in the default web browser."""
        try:
            from IPython import get_ipython
            from IPython.display import IFrame, display
        except ImportError:
            get_ipython = None
        if get_ipython is not None and get_ipython() is not None:
            display(IFrame(self.url, width="100%", height=height))
        else:
            import webbrowser

            webbrowser.open(self.url)

    def _repr_html_(self) -> str:
        return (f'<iframe src="{self.url}" width="100%" height="{IFRAME_HEIGHT}" '
                f'style="border:1px solid #ccc"></iframe>')

    def __repr__(self) -> str:
        state = "stopped" if self.stopped else "serving"
        return f"<skelcore inspector {state} at {self.url}>"

    def __enter__(self) -> "InspectorHandle":
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


def open_inspector(cloud: Cloud, params: ContractionParams = ContractionParams(), *, host: str = LOCAL_HOST,
                   port: int = 0, **session_options) -> InspectorHandle:
    """Serve the inspector on a validated cloud (port 0: a free one); session_options as app.main.serve's."""
    problem = host_problem(host)
    if problem:
        raise InputError(problem.replace("--host", "host"))
    server, inspector = serve(cloud, host, port, params=params, **session_options)
    return InspectorHandle(server, inspector, host)
