#!/usr/bin/env python3
"""Writes a gzip-compressed initramfs (cpio "newc") from a directory tree.
usage: mkcpio.py ROOTDIR OUT.cpio.gz"""
import gzip, os, stat, sys

def entries(root):
    yield ".", os.lstat(root)
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames.sort()
        for name in sorted(dirnames) + sorted(filenames):
            full = os.path.join(dirpath, name)
            yield os.path.relpath(full, root), os.lstat(full)

def header(ino, name, st, size):
    fields = [ino, st.st_mode, 0, 0, 1, int(st.st_mtime), size, 0, 0, 0, 0, len(name) + 1, 0]
    return ("070701" + "".join("%08X" % f for f in fields)).encode()

def pad(n):
    return b"\0" * ((4 - n % 4) % 4)

def main(root, out):
    with gzip.open(out, "wb", compresslevel=1) as f:
        ino = 1
        for rel, st in entries(root):
            full = os.path.join(root, rel)
            if stat.S_ISLNK(st.st_mode):
                data = os.readlink(full).encode()
            elif stat.S_ISREG(st.st_mode):
                with open(full, "rb") as g:
                    data = g.read()
            else:
                data = b""
            name = rel.encode()
            h = header(ino, name, st, len(data)) + name + b"\0"
            f.write(h + pad(len(h)) + data + pad(len(data)))
            ino += 1
        t = header(ino, b"TRAILER!!!", os.stat(root), 0) + b"TRAILER!!!\0"
        f.write(t + pad(len(t)))

if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
