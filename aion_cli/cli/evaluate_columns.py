"""The columns of ``aion evaluate``'s tables: heading scores (atc, lincoln, holdout),
activity forecasts (lincoln, holdout) and the paper's Table I (office).

Split from :mod:`aion_cli.cli.evaluate`; its commands print their results with these."""

from __future__ import annotations

from aion_cli.cli.output import Column, num
from aion_cli.number_text import mean_spread

SCORE_COLUMNS = (
    Column("model", "model", justify="left"),
    Column("detections", "detections", lambda v: f"{v:,}"),
    Column("unmatched", "unmatched", lambda v: f"{v:,}"),
    Column("nll_matched", "NLL (matched)", num(3)),
    Column("nll_all", "NLL (all)", num(3)),
    Column("chi_square", "chi²", num(3)),
)


ACTIVITY_COLUMNS = (
    Column("model", "model", justify="left"),
    Column("spearman", "Spearman", num(3)),
    Column("poisson_deviance", "Poisson dev.", num(0)),
    Column("mae", "MAE / hour", num(0)),
)
LINCOLN_ACTIVITY_COLUMNS = (
    *ACTIVITY_COLUMNS[:2],
    Column("spearman_rate", "Spearman (rates)", num(3)),
    *ACTIVITY_COLUMNS[2:],
)


TABLE_I_COLUMNS = (
    Column("map_type", "map type", justify="left"),
    Column("data_type", "data type", justify="left"),
    Column("js", "JS (ours)", mean_spread),
    Column("paper_js", "JS (paper)", mean_spread),
    Column("bhattacharyya", "Bhatt. (ours)", mean_spread),
    Column("paper_bhattacharyya", "Bhatt. (paper)", mean_spread),
    Column("wasserstein", "Wass. (ours)", mean_spread),
    Column("paper_wasserstein", "Wass. (paper)", mean_spread),
    Column("circular_correlation", "circ. r (ours)", mean_spread),
    Column("paper_circular_correlation", "circ. r (paper)", mean_spread),
)
