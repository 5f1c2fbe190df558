"""Paper A's setpoint table with the printed and the refitted quadratic."""

import json

import paths

from gyroid.plotting import paper_a_table, save

result = json.loads(paths.data("reproduce", "reproduce.json").read_text())
save(paper_a_table(result), paths.figure("paper_a_setpoint_table"), pdf=True)
