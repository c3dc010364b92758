#!/usr/bin/env python3
# Contact sheet of a sitepose sequence without OpenCV: pure-Python PNG
# decode (gray 8/16 bit), 3x subsampling, a 3x2 grid, PNG out.
# Usage: contact_sheet.py SEQ OUT.png F1,F2,F3,F4 masks|parts  (4 left frames,
# the right image of F2 and its instance or part mask).
import struct, sys, zlib

def read_png(path):
    data = open(path, 'rb').read()
    assert data[:8] == b'\x89PNG\r\n\x1a\n'
    pos, idat = 8, b''
    while pos < len(data):
        n, = struct.unpack('>I', data[pos:pos+4]); typ = data[pos+4:pos+8]; body = data[pos+8:pos+8+n]
        if typ == b'IHDR': w, h, depth, ctype = struct.unpack('>IIBB', body[:10])
        elif typ == b'IDAT': idat += body
        pos += 12 + n
    assert ctype == 0, ctype
    bpp = depth // 8
    raw = zlib.decompress(idat)
    stride = w * bpp
    rows, prev, i = [], bytearray(stride), 0
    for y in range(h):
        f = raw[i]; line = bytearray(raw[i+1:i+1+stride]); i += 1 + stride
        if f == 1:
            for x in range(bpp, stride): line[x] = (line[x] + line[x-bpp]) & 255
        elif f == 2:
            for x in range(stride): line[x] = (line[x] + prev[x]) & 255
        elif f == 3:
            for x in range(stride): line[x] = (line[x] + ((line[x-bpp] if x >= bpp else 0) + prev[x]) // 2) & 255
        elif f == 4:
            for x in range(stride):
                a = line[x-bpp] if x >= bpp else 0; b = prev[x]; c = prev[x-bpp] if x >= bpp else 0
                p = a + b - c; pa, pb, pc = abs(p-a), abs(p-b), abs(p-c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line)); prev = line
    if bpp == 2: rows = [bytes(min(255, (r[2*x] << 8 | r[2*x+1])) for x in range(w)) for r in rows]
    return w, h, rows

def tile(path, s=3, scale=1):
    w, h, rows = read_png(path)
    return [bytes(min(255, rows[y][x] * scale) for x in range(0, w, s)) for y in range(0, h, s)]

def write_png(path, rows):
    h, w = len(rows), len(rows[0])
    raw = b''.join(b'\x00' + r for r in rows)
    def chunk(t, b): return struct.pack('>I', len(b)) + t + b + struct.pack('>I', zlib.crc32(t + b) & 0xffffffff)
    open(path, 'wb').write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 0, 0, 0, 0)) +
                           chunk(b'IDAT', zlib.compress(raw, 9)) + chunk(b'IEND', b''))

seq, out, frames, mask_kind = sys.argv[1], sys.argv[2], [int(x) for x in sys.argv[3].split(',')], sys.argv[4]
tiles = [tile(f'{seq}/image_0/{k:06d}.png') for k in frames[:4]]
tiles.append(tile(f'{seq}/image_1/{frames[1]:06d}.png'))
if mask_kind == 'parts':
    tiles.append(tile(f'{seq}/labels/parts/{frames[1]:06d}.png', scale=45))
else:
    tiles.append(tile(f'{seq}/labels/masks/{frames[1]:06d}.png', scale=22))
th, tw = len(tiles[0]), len(tiles[0][0])
rows = []
for r in range(2):
    for y in range(th):
        rows.append(b'\xff'.join(tiles[r*3+c][y] for c in range(3)))
    if r == 0: rows.append(b'\xff' * len(rows[-1]))
write_png(out, rows)
print(out, len(rows[0]), 'x', len(rows))
