"""Analysis of logged runs: tables and figures regenerated from run directories."""
