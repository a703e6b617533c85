"""USD schema files shipped with phongscene (data only; registration lives in phongscene.usd)."""
