"""Sphinx glue for the API reference (loaded through ``sphinx.local_extensions`` in _config.yml).

YAML has no tuples, but Sphinx matches ``nitpick_ignore`` entries as ``(type, target)``
tuples; this turns the ``[type, target]`` pairs of _config.yml into tuples.
"""


def _tuples(app, config):
    for name in ("nitpick_ignore", "nitpick_ignore_regex"):
        value = getattr(config, name, None)
        if value:
            setattr(config, name, [tuple(v) for v in value])


def _one_blas_thread_in_kernels():
    """Chapter kernels (started by myst-nb from this process) inherit ``OPENBLAS_NUM_THREADS=1``.

    The chapters parallelise over Monte Carlo runs on a two-worker process pool whose workers
    already run BLAS on one thread (``pfrepro.montecarlo.process_pool``); a kernel's own BLAS
    threads spin against those workers and gain nothing on the small matrix products of these
    filters (the bearings-only PF(4000) ran 2.7x slower with two BLAS threads than with one
    on a loaded machine). Numbers do not change: the filters' outputs are bit-identical with
    one and two BLAS threads (checked for the PF, EKF, UKF, GPFF and the IMM filters). A value
    the user has set is kept.
    """
    import os
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def setup(app):
    _one_blas_thread_in_kernels()
    app.connect("config-inited", _tuples)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
