"""numpy arrays when numpy is installed, else lists of floats."""
try:
    import numpy
except ImportError:  # the client needs nothing beyond the standard library
    numpy = None


def array(values):
    return numpy.asarray(values, dtype=float) if numpy is not None else [float(v) for v in values]


def rows(flat, width):
    """flat's values, width at a time: an (n, width) array, else a list of
    lists."""
    flat = [float(v) for v in flat]
    if numpy is not None:
        return numpy.asarray(flat, dtype=float).reshape(-1, width)
    return [flat[i:i + width] for i in range(0, len(flat), width)]
