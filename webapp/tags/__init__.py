"""Tags on the database: the registry (issue, declare, layouts of placed sets) and
the scan path (cached look-ups, batched scan records)."""
