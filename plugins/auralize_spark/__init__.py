"""auralize_spark: spark-discharge and thunder sound with N-waves and WM-waves (paper 002)."""
