#!/usr/bin/env python3
"""Grab the X root window ($DISPLAY) to a PNG with only libX11 (ctypes) and zlib: no extra packages.

Usage (GUI Blender under Xvfb inside a root; bpy.ops.screen.screenshot gives a black image there):
  scripts/blender --use 5.2 --exec xvfb-run -a -s "-screen 0 1280x720x24" sh -c \
    'blender --factory-startup & sleep 25; python3 scripts/xgrab.py /tmp/shot.png; kill $!'
"""
import ctypes
import ctypes.util
import struct
import sys
import zlib

out = sys.argv[1]
X = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
X.XOpenDisplay.restype = ctypes.c_void_p
X.XOpenDisplay.argtypes = [ctypes.c_char_p]
X.XDefaultRootWindow.restype = ctypes.c_ulong
X.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
X.XDefaultScreen.argtypes = [ctypes.c_void_p]
X.XDisplayWidth.argtypes = X.XDisplayHeight.argtypes = [ctypes.c_void_p, ctypes.c_int]
X.XGetImage.restype = ctypes.c_void_p
X.XGetImage.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int, ctypes.c_uint, ctypes.c_uint,
                        ctypes.c_ulong, ctypes.c_int]


class XImage(ctypes.Structure):
    _fields_ = [("width", ctypes.c_int), ("height", ctypes.c_int), ("xoffset", ctypes.c_int), ("format", ctypes.c_int),
                ("data", ctypes.POINTER(ctypes.c_ubyte)), ("byte_order", ctypes.c_int), ("bitmap_unit", ctypes.c_int),
                ("bitmap_bit_order", ctypes.c_int), ("bitmap_pad", ctypes.c_int), ("depth", ctypes.c_int),
                ("bytes_per_line", ctypes.c_int), ("bits_per_pixel", ctypes.c_int)]


d = X.XOpenDisplay(None)
assert d, "cannot open display"
s = X.XDefaultScreen(d)
w, h = X.XDisplayWidth(d, s), X.XDisplayHeight(d, s)
ZPIXMAP = 2
img = ctypes.cast(X.XGetImage(d, X.XDefaultRootWindow(d), 0, 0, w, h, 0xFFFFFFFF, ZPIXMAP),
                  ctypes.POINTER(XImage)).contents
assert img.bits_per_pixel == 32, img.bits_per_pixel
raw = ctypes.string_at(img.data, img.bytes_per_line * h)
# fast BGRX -> RGB per row
buf = bytearray()
for y in range(h):
    line = raw[y * img.bytes_per_line: y * img.bytes_per_line + 4 * w]
    rgb = bytearray(3 * w)
    rgb[0::3], rgb[1::3], rgb[2::3] = line[2::4], line[1::4], line[0::4]
    buf += b"\0" + rgb


def chunk(t, data):
    return struct.pack(">I", len(data)) + t + data + struct.pack(">I", zlib.crc32(t + data) & 0xFFFFFFFF)


with open(out, "wb") as f:
    f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(bytes(buf), 6)) + chunk(b"IEND", b""))
print("grabbed", w, h, "->", out)
