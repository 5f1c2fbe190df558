"""Paper B Table 2: lateral error by eq. 8 in SI, exactly, as printed, and its bound."""

import json

import paths

from gyroid.plotting import paper_b_lateral, save

result = json.loads(paths.data("reproduce", "reproduce.json").read_text())
save(paper_b_lateral(result), paths.figure("paper_b_table2"), pdf=True)
for t, row in result["paper_b"]["table2"].items():
    print(f"t = {t:>3} s: eq. 8 {row['dr_z_m_eq8']:9.1f} m, exact {row['dr_z_m_exact']:9.1f} m, "
          f"printed {row['dr_z_printed']} (km)")
