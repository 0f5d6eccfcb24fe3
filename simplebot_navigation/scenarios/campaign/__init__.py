"""Scenario campaigns: the spec, running it on local workers or Ray, the results, statistics and plots
(docs/campaigns.md)."""
