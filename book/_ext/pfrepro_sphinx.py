"""Sphinx glue for the API reference (loaded through ``sphinx.local_extensions`` in _config.yml).

YAML has no tuples, but Sphinx matches ``nitpick_ignore`` entries as ``(type, target)``
tuples; this turns the ``[type, target]`` pairs of _config.yml into tuples.
"""


def _tuples(app, config):
    for name in ("nitpick_ignore", "nitpick_ignore_regex"):
        value = getattr(config, name, None)
        if value:
            setattr(config, name, [tuple(v) for v in value])


def setup(app):
    app.connect("config-inited", _tuples)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
