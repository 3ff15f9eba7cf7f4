"""Fault campaigns: many seeded headless runs swept over fault, wind and autopilot axes.

- :mod:`sim.campaign.axes`: the axes a campaign may sweep and their allowed values;
- :mod:`sim.campaign.spec`: campaign files (TOML), validated in one-line errors;
- :mod:`sim.campaign.expand`: a campaign as its list of runs, each a scenario and a stable id;
- :mod:`sim.campaign.rows`: one run's metrics as one flat row of results;
- :mod:`sim.campaign.worker`: what a Dask worker does (warm up once, fly runs);
- :mod:`sim.campaign.engine`: the runs as Dask tasks on a local or an existing cluster;
- :mod:`sim.campaign.store`: results as Parquet in the output directory, resumable;
- :mod:`sim.campaign.summary`, :mod:`sim.campaign.figures`, :mod:`sim.campaign.report`:
  the campaign's tables, figures and Markdown report;
- :mod:`sim.campaign.cli`: the ``ftc-campaign`` command; :mod:`sim.campaign.bench` its
  throughput benchmark (``ftc-bench campaign``).

Shipped campaign files live in ``sim/campaigns/``.
"""
