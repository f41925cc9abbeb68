"""Reading and writing the files of ``shared/formats.md``: calibrations, detections, scenes, routines, ground truth."""
