"""The files a generate run's tasks and benchmarks write, one module per format: a frozen
dataclass for the record, its one writer and its one reader (moonbot.records.base: the schema
version, field-path errors, atomic writes). task.json, gt.json, stats.json and DONE.json live in
a task directory (OUT/tasks/<task_id>/); none of them is copied into the merged dataset."""
