"""Campaigns: a scene family sampled by the dozen or hundred, each sample's truth and candidate run from
the same start, each judged by its outcome and, where the truth is well posed, by its distance to it.
One job per module:
  family   the family file: a scene plus `vary:` (field paths as --set writes them -> distributions), its
           samples (scrambled Halton points, seeded) as --set overrides, each checked as a scene is
  sample   one sample's runs (truth, its perturbed twin, the candidate) and what they decide
  verdict  the agreement rate and its 95 % Wilson interval, the error distribution, the worst samples
  runs     the samples' runs through the executor, each record kept in the out dir (a rerun resumes)
  search   the worst-case search (--search): the cross-entropy method over the vary: fields
  report   campaign.json, campaign.md, index.html (and a search's search.json)
The command: testbed/commands/campaign.py.
"""
