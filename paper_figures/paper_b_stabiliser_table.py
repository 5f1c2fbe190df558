"""Paper B's ideal-stabiliser angle error table (eq. 9)."""

import json

import paths

from gyroid.plotting import paper_b_stabiliser, save

result = json.loads(paths.data("reproduce", "reproduce.json").read_text())
save(paper_b_stabiliser(result), paths.figure("paper_b_stabiliser_table"), pdf=True)
