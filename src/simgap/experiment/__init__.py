"""Experiments: one run wired end to end (`single_run`); specs and samplers (`spec`, `samplers`);
the run a worker executes (`job`); executors (`executors`: local processes, Ray); the results
store (`store`); an experiment end to end with resume (`runner`); what a search found (`search_results`)."""
