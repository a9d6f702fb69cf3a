#!/usr/bin/env python3
"""Read an acc fleet store with engines acc did not write: DuckDB, pyarrow and Spark (local
mode, through pyspark; the recipe of docs/fleet.md).

Usage: fleet_engines.py duckdb|pyarrow|spark STORE [TOOL]

Prints one JSON object: per machine the number of period rows, the number of cut rows,
the sum of the cuts' time saved (s), the sum of kc_hat over the period rows, and for TOOL
(default 12) the Kc trend: mean kc_hat per machine and UTC hour. Exit 2 when the engine
does not import (the test then skips or, under CI, fails).
"""
import json
import sys


def with_duckdb(store, tool):
    import duckdb

    con = duckdb.connect()
    period = f"read_parquet('{store}/period/**/*.parquet', hive_partitioning = true)"
    cut = f"read_parquet('{store}/cut/**/*.parquet', hive_partitioning = true)"
    out = {}
    for m, n, kc in con.execute(
        f"SELECT machine, count(*), sum(kc_hat) FROM {period} GROUP BY machine"
    ).fetchall():
        out.setdefault(m, {})
        out[m]["periods"] = n
        out[m]["kc_sum"] = kc
    for m, n, saved in con.execute(
        f"SELECT machine, count(*), sum(time_saved_s) FROM {cut} GROUP BY machine"
    ).fetchall():
        out.setdefault(m, {})
        out[m]["cuts"] = n
        out[m]["time_saved_s"] = saved
    for m, hour, kc in con.execute(
        f"SELECT machine, strftime(date_trunc('hour', ts AT TIME ZONE 'UTC'), '%Y-%m-%dT%H'),"
        f" avg(kc_hat) FROM {period} WHERE tool = {tool} AND kc_hat IS NOT NULL"
        f" GROUP BY 1, 2 ORDER BY 1, 2"
    ).fetchall():
        out.setdefault(m, {}).setdefault("kc_trend", []).append([hour, kc])
    return out


def with_pyarrow(store, tool):
    import pyarrow.compute as pc
    import pyarrow.dataset as ds

    def table(name):
        return ds.dataset(f"{store}/{name}", format="parquet", partitioning="hive").to_table()

    out = {}
    period = table("period")
    for row in period.group_by("machine").aggregate([("period", "count"), ("kc_hat", "sum")]).to_pylist():
        m = row["machine"]
        out.setdefault(m, {})
        out[m]["periods"] = row["period_count"]
        out[m]["kc_sum"] = row["kc_hat_sum"]
    cut = table("cut")
    for row in cut.group_by("machine").aggregate([("time_saved_s", "count"), ("time_saved_s", "sum")]).to_pylist():
        m = row["machine"]
        out.setdefault(m, {})
        out[m]["cuts"] = row["time_saved_s_count"]
        out[m]["time_saved_s"] = row["time_saved_s_sum"]
    t = period.filter(pc.and_(pc.equal(period["tool"], tool), pc.is_valid(period["kc_hat"])))
    hours = pc.strftime(pc.floor_temporal(t["ts"], unit="hour"), format="%Y-%m-%dT%H")
    t = t.append_column("hour", hours)
    rows = t.group_by(["machine", "hour"]).aggregate([("kc_hat", "mean")]).to_pylist()
    for row in sorted(rows, key=lambda r: (r["machine"], r["hour"])):
        out.setdefault(row["machine"], {}).setdefault("kc_trend", []).append([row["hour"], row["kc_hat_mean"]])
    return out


def with_spark(store, tool):
    from pyspark.sql import SparkSession

    spark = (
        SparkSession.builder.master("local[2]")
        .appName("acc-fleet-check")
        .config("spark.ui.enabled", "false")
        .config("spark.ui.showConsoleProgress", "false")
        .config("spark.sql.session.timeZone", "UTC")
        .getOrCreate()
    )
    spark.sparkContext.setLogLevel("ERROR")
    for name in ("period", "cut"):
        path = f"{store}/{name}"
        spark.read.option("basePath", path).parquet(path).createOrReplaceTempView(name)
    out = {}
    for m, n, kc in spark.sql(
        "SELECT machine, count(*), sum(kc_hat) FROM period GROUP BY machine"
    ).collect():
        out.setdefault(m, {})
        out[m]["periods"] = n
        out[m]["kc_sum"] = kc
    for m, n, saved in spark.sql(
        "SELECT machine, count(*), sum(time_saved_s) FROM cut GROUP BY machine"
    ).collect():
        out.setdefault(m, {})
        out[m]["cuts"] = n
        out[m]["time_saved_s"] = saved
    for m, hour, kc in spark.sql(
        "SELECT machine, date_format(date_trunc('HOUR', ts), \"yyyy-MM-dd'T'HH\"), avg(kc_hat)"
        f" FROM period WHERE tool = {tool} AND kc_hat IS NOT NULL GROUP BY 1, 2 ORDER BY 1, 2"
    ).collect():
        out.setdefault(m, {}).setdefault("kc_trend", []).append([hour, kc])
    spark.stop()
    return out


def main():
    engine, store = sys.argv[1], sys.argv[2]
    tool = int(sys.argv[3]) if len(sys.argv) > 3 else 12
    try:
        result = {"duckdb": with_duckdb, "pyarrow": with_pyarrow, "spark": with_spark}[engine](store, tool)
    except ImportError as e:
        print(f"{engine} does not import: {e}", file=sys.stderr)
        sys.exit(2)
    print(json.dumps(result, sort_keys=True))


if __name__ == "__main__":
    main()
