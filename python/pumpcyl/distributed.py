"""pumpcyl on a Dask cluster (docs/beyond-one-machine.md): a grid identification split into
shards, sweeps of margins, designs or selections over many rigs, and a fleet of experiments
identified one each.

pumpcyl brings no scheduler of its own: these functions hand independent pieces of work to a
``dask.distributed.Client`` (a ``LocalCluster`` on a laptop, dask-jobqueue on Slurm, PBS or
SGE) and gather them. Only serialised results cross process boundaries: the arguments are
paths, rig TOML text and plain dicts, and each worker returns the JSON text of the core's
document (for a shard, the partial result ``pumpcyl identify --shard`` writes). A worker that
dies is retried by Dask; the pieces are pure, so the answer does not change.

Needs the optional dependencies: ``pip install "pumpcyl[dask]"`` (dask, distributed, pandas).
"""

import itertools
import json
import math
import os

import pumpcyl
from pumpcyl._pumpcyl import _check_shards

__all__ = ["identify", "sweep", "identify_many"]

# Which analyses `sweep` runs, by name.
ANALYSES = ("margins", "design", "select")


def _client(client):
    """The client given, else the current one (``distributed.get_client``)."""
    if client is not None:
        return client
    from distributed import get_client

    return get_client()


def _threads(client):
    """The threads of the cluster's workers, at least 1."""
    return max(1, sum(client.nthreads().values()))


# ---------------------------------------------------------------------------------------------
# Sharded identification


def _identify_shard(experiment, i, n, options):
    """On a worker: shard ``i`` of ``n`` of the experiment file (its JSON text)."""
    return pumpcyl.identify(experiment, shard=(i, n), **options)


def identify(experiment, *, client=None, shards=None, **options):
    """The grid identification of the experiment file ``experiment`` (the article §2.4.4) with
    its grids split into ``shards`` slices run on the Dask ``client`` (default: the current
    client), merged with the checks of ``pumpcyl identify-merge``
    (docs/identification.md#sharding).

    The answer is the one-process ``pumpcyl.identify(path)`` of the file's canonical path:
    every field equal (the test compares them with ``==``) but ``seconds`` (here the shards'
    search time added up, plus the merge's) and how the rejected candidates split into
    ``pruned`` and ``unstable``, which depends on the order in which they are met and differs
    between two one-process runs too. ``shards`` defaults to twice the cluster's threads; at
    most 1000 and the candidates of the smaller grid. ``options``: ``threshold_mm2``, ``top``,
    ``local_refinement``, ``allow_long_run`` as for :func:`pumpcyl.identify`; the grids are the
    file's (a sharded run needs both fixed: give ``refined_grid`` in the file).

    The workers read the experiment file and its records by the same path: on a cluster of
    several machines it must be on a shared file system.
    """
    client = _client(client)
    path = os.path.realpath(os.fspath(experiment))
    n = shards if shards is not None else 2 * _threads(client)
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise pumpcyl.PumpcylError(f"identify(shards={n!r}): a whole number >= 1")
    _check_shards(path, n)  # once here, rather than every shard refusing on its worker
    futures = client.map(
        _identify_shard,
        [path] * n,
        range(1, n + 1),
        [n] * n,
        [options] * n,
        key=[f"pumpcyl-shard-{i}-of-{n}-{os.urandom(4).hex()}" for i in range(1, n + 1)],
    )
    return pumpcyl.identify_merge(client.gather(futures))


# ---------------------------------------------------------------------------------------------
# Rows of a DataFrame: shared by `sweep` and `identify_many`


def _run_batch(analysis, items, options):
    """On a worker: ``analysis`` of each item (JSON text each), each its JSON text
    ``{"result": ...}`` or ``{"error": "..."}``: one failure does not take the others down."""
    out = []
    for item in items:
        try:
            result = _ANALYSE[analysis](json.loads(item), options)
            out.append(json.dumps({"result": result.to_dict()}))
        except Exception as e:  # noqa: BLE001 - the error goes into its row
            out.append(json.dumps({"error": _message(e)}))
    return out


def _message(e):
    """An exception as one line: pumpcyl's own message, others prefixed by their type."""
    text = " ".join(str(e).split())
    return text if isinstance(e, pumpcyl.PumpcylError) else f"{type(e).__name__}: {text}"


def _rig_of(item):
    """The rig of a sweep item: rig TOML text (a Rig of the list, or the sweep's base rig),
    with keyword overrides where it has them, or overrides of the article's rig."""
    if "toml" in item:
        rig = pumpcyl.Rig.from_toml_str(item["toml"], item["name"])
        overrides = item.get("overrides")
        return rig.replace(**overrides) if overrides else rig
    return pumpcyl.Rig(**item["overrides"])


_ANALYSE = {
    "margins": lambda item, o: pumpcyl.margins(_rig_of(item), **o),
    "design": lambda item, o: pumpcyl.design(_rig_of(item), **o),
    "select": lambda item, o: pumpcyl.select(rig=_rig_of(item), **o),
    "identify": lambda item, o: pumpcyl.identify(item["experiment"], **o),
}


def _map_batches(client, analysis, items, options, batch_size):
    """``analysis`` over ``items`` (JSON-able dicts) on the cluster, ``batch_size`` items a
    task (default: about four tasks per thread); the parsed answers in the items' order."""
    client = _client(client)
    if batch_size is None:
        batch_size = max(1, math.ceil(len(items) / (4 * _threads(client))))
    if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
        raise pumpcyl.PumpcylError(f"batch_size={batch_size!r}: a whole number >= 1")
    texts = [json.dumps(item) for item in items]
    batches = [texts[k : k + batch_size] for k in range(0, len(texts), batch_size)]
    tag = os.urandom(4).hex()
    futures = client.map(
        _run_batch,
        [analysis] * len(batches),
        batches,
        [options] * len(batches),
        key=[f"pumpcyl-{analysis}-{k}-{tag}" for k in range(len(batches))],
    )
    return [json.loads(text) for batch in client.gather(futures) for text in batch]


def _frame(labels, answers, columns):
    """A DataFrame, one row an item: its ``labels``, then ``columns(result)`` (a dict) of its
    result, ``error`` (None when it ran) and ``result``, the whole document as a dict."""
    import pandas

    rows = []
    for label, answer in zip(labels, answers):
        result = answer.get("result")
        row = dict(label)
        row.update(columns(result) if result is not None else {})
        row["error"] = answer.get("error")
        row["result"] = result
        rows.append(row)
    frame = pandas.DataFrame(rows)
    # None, not NaN, where there is no error: the column holds texts
    frame["error"] = pandas.Series([row["error"] for row in rows], dtype=object)
    return frame


def _scalars(result):
    """The fields of a document that are numbers, flags or texts (None included), and one
    level of its dicts of them as ``outer.inner``."""
    out = {}
    for k, v in result.items():
        if isinstance(v, dict):
            out.update({f"{k}.{j}": x for j, x in v.items() if _is_scalar(x)})
        elif _is_scalar(v):
            out[k] = v
    return out


def _is_scalar(v):
    return v is None or isinstance(v, (bool, int, float, str))


# ---------------------------------------------------------------------------------------------
# Sweeps over rigs


def _base_rig(rig):
    """The sweep's base rig as (TOML text, name for messages): None for the article's rig, a
    :class:`pumpcyl.Rig`, or the path of a rig TOML file, read here (the workers get its text,
    so they need not see the file)."""
    if rig is None:
        return None
    if isinstance(rig, pumpcyl.Rig):
        return rig.to_toml(), "rig"
    if isinstance(rig, (str, os.PathLike)):
        return pumpcyl.Rig.from_toml(rig).to_toml(), os.fspath(rig)
    raise pumpcyl.PumpcylError(
        f"sweep(rig={rig!r:.60}): a Rig, the path of a rig TOML file, or None (the article's rig)"
    )


def _differing_keys(rigs):
    """The keys whose values (numbers, flags, texts) differ between the Rigs ``rigs``, in the
    rigs' key order."""
    tables = [r.to_dict() for r in rigs]
    if len(tables) < 2:
        return []
    return [
        key for key, value in tables[0].items()
        if _is_scalar(value) and any(t.get(key) != value for t in tables[1:])
    ]


def _sweep_items(rigs_or_overrides, base=None):
    """The sweep's items and each one's label columns: a dict of lists is the product of its
    values (one rig each combination), a list holds Rigs or dicts of overrides. Overrides apply
    to ``base`` (TOML text and name, :func:`_base_rig`), the article's rig when None; a dict's
    label is its overrides, a Rig's its place in the list (``rig``: ``rigs[k]``) and the keys in
    which the list's Rigs differ from each other."""
    if isinstance(rigs_or_overrides, dict):
        keys = list(rigs_or_overrides)
        axes = [list(rigs_or_overrides[k]) for k in keys]
        given = [dict(zip(keys, values)) for values in itertools.product(*axes)]
    else:
        given = list(rigs_or_overrides)
    differing = _differing_keys([g for g in given if isinstance(g, pumpcyl.Rig)])
    items, labels = [], []
    for k, g in enumerate(given):
        if isinstance(g, pumpcyl.Rig):
            items.append({"toml": g.to_toml(), "name": f"rigs[{k}]"})
            values = g.to_dict()
            labels.append({"rig": f"rigs[{k}]", **{key: values[key] for key in differing}})
        elif isinstance(g, dict):
            plain = json.loads(json.dumps(g, default=_plain))
            if base is None:
                items.append({"overrides": plain})
            else:
                items.append({"toml": base[0], "name": base[1], "overrides": plain})
            labels.append(plain)
        else:
            raise pumpcyl.PumpcylError(
                f"sweep(rigs_or_overrides[{k}]={g!r:.60}): a Rig or a dict of rig keys"
            )
    return items, labels


def _plain(v):
    """numpy values as Python's own, for JSON."""
    if hasattr(v, "tolist"):
        return v.tolist()
    raise TypeError(f"{v!r:.60} is not a number, text, list or dict")


def sweep(rigs_or_overrides, analysis="margins", *, rig=None, client=None, batch_size=None,
          **options):
    """``analysis`` ("margins", "design" or "select") of many rigs on the Dask ``client``
    (default: the current client), as a pandas DataFrame with one row a rig.

    ``rigs_or_overrides``: a list of :class:`pumpcyl.Rig` or of dicts of rig keys (overrides
    of the base rig, as ``base.replace(**overrides)``), or a dict of lists, whose product is
    swept (``{"mass_kg": [4898, 10593], "beta_bar": [60, 120, 165]}``: six rigs). ``rig``: the
    base rig the overrides apply to, a :class:`pumpcyl.Rig` or the path of a rig TOML file
    (read here, so the workers need not see it); None, the default, the article's rig. A Rig
    of the list is swept as it is. ``options`` go to the analysis (``target_pm_deg=40`` for
    design, ``gas_fraction_max=0.1`` for select).

    Columns: the overrides, or for a Rig of the list ``rig`` (``rigs[k]``, its place in the
    list) and the keys in which the list's Rigs differ; the result's numbers, flags and texts
    (one level of its dicts as ``outer.inner``), ``error`` (the message of a rig that failed,
    None otherwise: a failure never takes the other rows down) and ``result``, the whole
    document as a dict: equal to ``pumpcyl.margins(rig).to_dict()`` of the same rig. Rigs go to
    the workers as TOML text or overrides, in batches of ``batch_size`` (default: about four
    tasks per worker thread); the dashboard shows the batches' progress.
    """
    if analysis not in ANALYSES:
        raise pumpcyl.PumpcylError(
            f"sweep(analysis={analysis!r}): one of {', '.join(map(repr, ANALYSES))}"
        )
    items, labels = _sweep_items(rigs_or_overrides, _base_rig(rig))
    answers = _map_batches(client, analysis, items, options, batch_size)
    return _frame(labels, answers, _scalars)


# ---------------------------------------------------------------------------------------------
# A fleet of experiments


def _identified(result):
    """The columns of an identification: the answer, its cost, and each parameter's interval
    as ``<name>_low``, ``<name>_high`` when the uncertainty was analysed."""
    keys = (
        "beta_bar",
        "viscous_friction_ns_per_m",
        "c12_m5_per_ns",
        "c1_m5_per_ns",
        "c2_m5_per_ns",
        "cost_mm2",
        "candidates_evaluated",
        "noise_std_mm",
        "confidence",
    )
    out = {k: result[k] for k in keys if k in result}
    for name, (low, high) in result.get("intervals", {}).items():
        out[f"{name}_low"], out[f"{name}_high"] = low, high
    for name, ok in result.get("identifiable", {}).items():
        out[f"{name}_identifiable"] = ok
    return out


def identify_many(records, *, client=None, uncertainty=True, confidence=0.95, **options):
    """One identification each (the article §2.4.4) of a fleet of experiment files on the Dask
    ``client`` (default: the current client), as a pandas DataFrame with one row an
    experiment.

    ``records``: a list of experiment TOML paths, or a dict {name: path}. Each is identified
    whole on one worker, as ``pumpcyl.identify(path, uncertainty=uncertainty,
    confidence=confidence, **options)``; with ``uncertainty`` (the default) its
    profile-likelihood intervals (docs/identification.md, "Uncertainty") are the columns
    ``beta_bar_low``, ``beta_bar_high`` and so on. Columns: ``record`` (the name or the path),
    ``experiment`` (the path), beta_bar, viscous_friction_ns_per_m, c12_m5_per_ns, c1, c2,
    cost_mm2, the intervals and ``<name>_identifiable``, ``error`` (why an experiment failed:
    a bad file never takes the other rows down) and ``result``, the whole document.
    """
    named = records.items() if isinstance(records, dict) else ((r, r) for r in records)
    labels, items = [], []
    for name, path in named:
        path = os.path.realpath(os.fspath(path))
        labels.append({"record": os.fspath(name), "experiment": path})
        items.append({"experiment": path})
    options = dict(options, uncertainty=uncertainty, confidence=confidence)
    answers = _map_batches(client, "identify", items, options, 1)
    return _frame(labels, answers, _identified)
