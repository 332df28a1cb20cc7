"""Campaigns: a scene family sampled by the dozen or hundred, each sample's truth and candidate run from
the same start, each judged by its outcome and, where the truth is well posed, by its distance to it.
One job per module:
  family   the family file: a scene plus `vary:` (field paths as --set writes them -> distributions), its
           samples (scrambled Halton points, seeded) as --set overrides, each checked as a scene is
  sample   one sample's runs (truth, its perturbed twin, the candidate) and what they decide
  verdict  the agreement rate and its 95 % Wilson interval, the error distribution, the worst samples
  report   campaign.json, campaign.md, index.html
The command: testbed/commands/campaign.py.
"""
