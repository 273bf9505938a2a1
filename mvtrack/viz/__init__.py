"""The visual debugger: the pipeline's intermediates logged to Rerun (`mvtrack-view`).

Only this package, the CLI and ``viewer_blueprints`` import ``rerun``.
"""

from mvtrack.viz.sink import APP_ID, LogOptions, RerunSink, new_recording

__all__ = ["APP_ID", "LogOptions", "RerunSink", "new_recording"]
