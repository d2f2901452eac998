"""`racer analyze`: simtrace logs (DeepRacer's or racer's own) -> tables, pictures and an HTML report.

sources (find the CSVs in a folder, tar.gz, bucket or store prefix) -> loading (one DataFrame of steps) ->
aggregate (episodes, iterations, workers, evaluation laps) -> plots / report; whatif replays a reward function.
pipeline runs these steps into an Analysis (results), with the run's track found by run_track and the report's
sections chosen by report_contents.
"""
