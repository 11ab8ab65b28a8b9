"""The Calibration tab: which manoeuvres calibrate a ship's magnetometer."""
