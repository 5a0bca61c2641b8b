-- A copy of the PostgreSQL study :src named :dst, in the same database, for bench_paired_pg (docs/studies.md):
--   psql 'postgresql://…/DB?host=…' -v src=NAME -v dst=COPY -f bench/store/pg_copy_study.sql
-- Trials keep their ids; saved states and snapshots are copied in their order (new serial ids).
BEGIN;
INSERT INTO varbo_studies SELECT :'dst', created_at FROM varbo_studies WHERE name = :'src';
INSERT INTO varbo_meta SELECT :'dst', key, value FROM varbo_meta WHERE study = :'src';
CREATE TEMP TABLE t ON COMMIT DROP AS SELECT * FROM varbo_trials WHERE study = :'src';
UPDATE t SET study = :'dst';
INSERT INTO varbo_trials SELECT * FROM t;
INSERT INTO varbo_algorithm_states (study, finished, outstanding, state, created_at)
  SELECT :'dst', finished, outstanding, state, created_at FROM varbo_algorithm_states WHERE study = :'src' ORDER BY id;
INSERT INTO varbo_snapshots (study, after_trials, iteration, objective, note, region_state, hyperparameters)
  SELECT :'dst', after_trials, iteration, objective, note, region_state, hyperparameters FROM varbo_snapshots WHERE study = :'src' ORDER BY id;
COMMIT;
