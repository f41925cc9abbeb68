"""OpenCV FileStorage numbers (YAML / XML), shared by the EasyMocap and WILDTRACK readers.

Paper: Section III-B's ``K_c``, ``R_c``, ``t_c`` as OpenCV stores them (``opencv-matrix`` nodes
or plain lists), returned as float64 arrays of the stored shape.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np

from ...errors import CalibrationError

__all__ = ["open_filestorage", "filestorage_numbers", "read_opencv_xml_numbers"]


def open_filestorage(path: Path) -> cv2.FileStorage:
    if not path.is_file():
        raise CalibrationError("file not found", source=path)
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:  # OpenCV's parse errors surface as either
        cause = exc.__cause__ or exc
        msg = str(cause).strip().splitlines()[-1] if str(cause).strip() else "unreadable"
        raise CalibrationError(f"not a readable OpenCV FileStorage file: {msg}", source=path) from None
    if not fs.isOpened() or not fs.root().isMap():
        raise CalibrationError("not a readable OpenCV FileStorage file (no top-level mapping)", source=path)
    return fs


def filestorage_numbers(node: cv2.FileNode, source, field: str) -> np.ndarray | None:
    """Numbers of a FileStorage node: an ``opencv-matrix``, a plain sequence or a scalar; None if
    the node is absent."""
    if node.empty() or node.isNone():
        return None
    if node.isMap():
        try:
            m = node.mat()
        except cv2.error:
            m = None
        if m is None:
            raise CalibrationError("expected an opencv-matrix (rows, cols, dt, data)", source=source, field=field)
        return np.asarray(m, dtype=np.float64)
    if node.isSeq():
        vals = []
        for i in range(node.size()):
            item = node.at(i)
            if not (item.isReal() or item.isInt()):
                raise CalibrationError(f"item {i} is not a number", source=source, field=field)
            vals.append(item.real())
        return np.asarray(vals, dtype=np.float64)
    if node.isReal() or node.isInt():
        return np.asarray(node.real(), dtype=np.float64)
    raise CalibrationError("expected numbers", source=source, field=field)



def read_opencv_xml_numbers(path: Path, key: str, error=CalibrationError) -> np.ndarray | None:
    """Numbers stored under ``key`` in an OpenCV FileStorage XML file (matrix or plain list).

    Reads with ``cv2.FileStorage``; when OpenCV cannot parse the file, falls back to
    ``xml.etree`` (``<key>`` text or its ``<data>`` child). None when ``key`` is absent.
    """
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
        ok = fs.isOpened() and fs.root().isMap()
    except (cv2.error, SystemError):
        ok, fs = False, None
    if ok:
        try:
            return filestorage_numbers(fs.getNode(key), path, key)
        finally:
            fs.release()
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise error(f"not a readable OpenCV XML file: {exc}", source=path) from None
    el = root.find(key)
    if el is None:
        return None
    data = el.find("data")
    text = (data.text if data is not None else el.text) or ""
    try:
        vals = np.array(text.split(), dtype=np.float64)
    except ValueError:
        raise error("expected numbers", source=path, field=key) from None
    rows, cols = el.find("rows"), el.find("cols")
    if data is not None and rows is not None and cols is not None:
        try:
            vals = vals.reshape(int(rows.text), int(cols.text))
        except (TypeError, ValueError):
            raise error("rows x cols does not match the data", source=path, field=key) from None
    return vals
