#!/usr/bin/env python3
"""Writes the seed corpus of tests/integration/fuzz.rs (run from this folder).

Every case of issue 31 that a file can carry is here, with valid inputs of each kind
for the mutator to start from. Deterministic: the same files every run. Files named
found_* are inputs the fuzz test found; they are kept as they were, not written here.
"""
import json, math, os, random, struct

random.seed(31)
RATE, SECONDS = 16000, 0.2
N = int(RATE * SECONDS)


def signal(channels, delay=3):
    """A noise burst reaching channel 1 `delay` samples after channel 0."""
    src = [random.gauss(0, 0.2) if 800 < k < 2600 else random.gauss(0, 0.002) for k in range(N + 16)]
    return [[src[k + 8 - c * delay] for c in range(channels)] for k in range(N)]


def pcm16(frames):
    return b"".join(struct.pack("<h", max(-32768, min(32767, int(v * 32767)))) for f in frames for v in f)


def fmt_chunk(channels, bits=16, code=1, rate=RATE, extensible=False):
    align = channels * bits // 8
    body = struct.pack("<HHIIHH", 0xFFFE if extensible else code, channels, rate, rate * align, align, bits)
    if extensible:
        guid = struct.pack("<H", code) + b"\x00\x00\x00\x00\x10\x00\x80\x00\x00\xaa\x00\x38\x9b\x71"
        body += struct.pack("<HHI", 22, bits, (1 << channels) - 1) + guid
    return b"fmt " + struct.pack("<I", len(body)) + body


def wav(data, fmt, riff_size=None, data_size=None, extra=b"", before=b"", magic=b"RIFF"):
    chunks = before + fmt + b"data" + struct.pack("<I", len(data) if data_size is None else data_size) + data
    if len(data) % 2:
        chunks += b"\x00"
    chunks += extra
    size = 4 + len(chunks) if riff_size is None else riff_size
    return magic + struct.pack("<I", size) + b"WAVE" + chunks


def write(path, content):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb" if isinstance(content, bytes) else "w") as f:
        f.write(content)


two = signal(2)
d16 = pcm16(two)
w = "wav/"
write(w + "pcm16.wav", wav(d16, fmt_chunk(2)))
write(w + "mono.wav", wav(pcm16([[f[0]] for f in two]), fmt_chunk(1)))
write(w + "float32.wav", wav(b"".join(struct.pack("<f", v) for f in two for v in f), fmt_chunk(2, 32, 3)))
d24 = b"".join(struct.pack("<i", int(v * 8388607))[:3] for f in two for v in f)
write(w + "extensible24.wav", wav(d24, fmt_chunk(2, 24, 1, extensible=True)))
write(w + "placeholder_ff.wav", wav(d16, fmt_chunk(2), 0xFFFFFFFF, 0xFFFFFFFF))
write(w + "placeholder_zero.wav", wav(d16, fmt_chunk(2), 0, 0))
full = wav(d16, fmt_chunk(2))
write(w + "truncated_odd.wav", full[: len(full) * 2 // 3 + 1])
write(w + "truncated_at_frames.wav", full[: 44 + 4 * 1000])
write(w + "partial_frame.wav", wav(d16 + b"\x01\x02\x03", fmt_chunk(2), 0xFFFFFFFF, 0xFFFFFFFF))
write(w + "declared_not_whole_frames.wav", wav(d16[:-1], fmt_chunk(2)))
write(w + "two_fmt.wav", wav(d16, fmt_chunk(2), before=fmt_chunk(1)))
write(w + "list_after_data.wav", wav(d16, fmt_chunk(2), extra=b"LIST" + struct.pack("<I", 4) + b"INFO"))
write(w + "second_data_chunk.wav", wav(d16, fmt_chunk(2), extra=b"data" + struct.pack("<I", 4) + b"\x00" * 4))
nan = b"".join(struct.pack("<f", v) for f in two for v in f)
nan = nan[:400] + struct.pack("<f", float("nan")) + nan[404:]
write(w + "nan_float.wav", wav(nan, fmt_chunk(2, 32, 3)))
ds64 = b"ds64" + struct.pack("<IQQQI", 28, 0, len(d16), N, 0)
write(w + "rf64.wav", wav(d16, fmt_chunk(2), 0xFFFFFFFF, 0xFFFFFFFF, before=ds64, magic=b"RF64"))
write(w + "header_promises_a_gigabyte.wav", wav(b"", fmt_chunk(2), data_size=1 << 30))
write(w + "wide_1024_channels_768k.wav", wav(b"\x00" * 2048 * 20, fmt_chunk(1024, rate=768000), 0xFFFFFFFF, 0xFFFFFFFF))
write(w + "float64.wav", wav(b"\x00" * 64, fmt_chunk(2, 64, 3)))
write(w + "empty.wav", b"")
write(w + "not_riff.wav", b"ID3\x03\x00\x00\x00\x00\x00\x00" + bytes(range(64)))
write(w + "silence.wav", wav(b"\x00" * len(d16), fmt_chunk(2)))

g = "geometry/"
pair = "[[mic]]\nposition = [0.1, 0.0, 0.0]\n[[mic]]\nposition = [-0.1, 0.0, 0.0]\n"
write(g + "pair.toml", "name = \"pair\"\nspeed_of_sound = 343.0\n" + pair)
square = "".join(f"[[mic]]\nposition = [{0.1 * math.cos(a):.4f}, {0.1 * math.sin(a):.4f}, 0.0]\nchannel = {i}\n"
                 for i, a in enumerate(k * math.pi / 2 for k in range(4)))
write(g + "square_planar.toml", "side = [0.0, 0.0, 1.0]\n" + square)
write(g + "tetra.toml", "[[mic]]\nposition = [0.1, 0.0, 0.0]\n[[mic]]\nposition = [-0.1, 0.0, 0.0]\n"
      "[[mic]]\nposition = [0.0, 0.1, 0.05]\n[[mic]]\nposition = [0.0, -0.1, -0.05]\n")
write(g + "extra_number.toml", "[[mic]]\nposition = [0.1, 0, 0, 1000]\n[[mic]]\nposition = [-0.1, 0, 0]\n")
write(g + "side_extra.toml", "side = [0, 0, 1, 5]\n" + square)
write(g + "speed_tiny.toml", "speed_of_sound = 1e-308\n" + pair)
write(g + "same_position.toml", "[[mic]]\nposition = [0.0, 0, 0]\n[[mic]]\nposition = [0.0, 0, 0]\n")
write(g + "ten_microns.toml", "[[mic]]\nposition = [0.0, 0, 0]\n[[mic]]\nposition = [0.00001, 0, 0]\n")
write(g + "escape_name.toml", "name = \"a\\u001b[2Jb\"\n" + pair)
write(g + "huge.toml", "[[mic]]\nposition = [1e300, 0, 0]\n[[mic]]\nposition = [-1e300, 0, 0]\n")
write(g + "duplicate_channel.toml", "[[mic]]\nposition = [0.1, 0, 0]\nchannel = 0\n[[mic]]\nposition = [-0.1, 0, 0]\nchannel = 0\n")
write(g + "empty.toml", "")

s = "scene/"
write(s + "arrays/pair.toml", pair)
head = f"sample_rate = {RATE}\nduration = 0.2\nseed = 3\n[array]\ngeometry = \"arrays/pair.toml\"\nposition = [2.0, 2.0, 1.0]\n"
src = "[[source]]\nazimuth_deg = 30.0\ndistance = 1.0\nsignal = \"white\"\nactive = [[0.05, 0.15]]\n"
write(s + "free.toml", head + src)
write(s + "room.toml", head + "[room]\ndimensions = [4.0, 3.0, 2.5]\nrt60 = 0.1\n" + src)
write(s + "noise.toml", head + src + "[noise]\nsnr_db = 10\nsensor_db = -70\n[[noise.fan]]\nposition = [3.0, 3.0, 1.0]\nsignal = \"pink\"\n[noise.diffuse]\nsignal = \"pink\"\nweight_db = -6\n")
write(s + "file_source.toml", head + "[[source]]\nazimuth_deg = -60.0\ndistance = 1.5\nsignal = \"file\"\nfile = \"../wav/mono.wav\"\n")
write(s + "moving.toml", head + "[[source]]\nazimuth_deg = 0.0\ndistance = 1.0\nsignal = \"pink\"\nturn_deg_per_s = 90\n")
write(s + "extra_numbers.toml", head.replace("[2.0, 2.0, 1.0]", "[2.0, 2.0, 1.0, 7.0]") + src.replace("[[0.05, 0.15]]", "[[0.05, 0.1, 0.15]]"))
write(s + "weight_nan.toml", head + src + "[noise]\nsnr_db = 10\n[[noise.fan]]\nposition = [3.0, 3.0, 1.0]\nsignal = \"pink\"\nweight_db = -1e9\n")
write(s + "duration_huge.toml", head.replace("duration = 0.2", "duration = 1e300") + src)
write(s + "many_intervals.toml", head + src.replace("[[0.05, 0.15]]", "[" + ", ".join(f"[{k * 0.001:.3f}, {k * 0.001 + 0.0005:.4f}]" for k in range(150)) + "]"))
write(s + "clicks_tone.toml", head + "[[source]]\nposition = [1.0, 1.0, 1.0]\nsignal = \"clicks\"\nrate = 20\n[[source]]\nazimuth_deg = 90.0\ndistance = 2.0\nsignal = \"tone\"\nfrequency = 700\nlevel_db = -30\n")

r = "result/"
header = "time_s,azimuth_deg,elevation_deg,x,y,z,score,file,frame,mics,source\n"
rows = "".join(f"{0.02 * k:.6f},30.0,0.0,0.866025,0.5,0.0,3.5,pcm16.wav,{k},2,1\n" for k in range(1, 9))
write(r + "rows.csv", header + rows)
write(r + "bom.csv", "\ufeff" + header + rows)
write(r + "inf_time.csv", header + "inf,30,10,0.85,0.49,0.17,5,a.wav,9,8,1\n")
ev_header = "file,source,start_s,end_s,azimuth_deg,elevation_deg,x,y,z,spread_deg,detections,score\n"
write(r + "events.csv", ev_header + "a.wav,1,0.1,0.5,30,10,0.85,0.49,0.17,0.1,40,5\n")
write(r + "events_infinity.csv", ev_header + "a.wav,1,0.1,Infinity,30,10,0.85,0.49,0.17,0.1,40,5\n")
recs = [dict(time_s=0.02 * k, azimuth_deg=30.0, elevation_deg=0.0, x=0.866025, y=0.5, z=0.0, score=3.5, file="pcm16.wav", frame=k, mics=2, source=1) for k in range(1, 6)]
event = dict(file="pcm16.wav", source=1, start_s=0.02, end_s=0.1, azimuth_deg=30.0, elevation_deg=0.0, x=0.866025, y=0.5, z=0.0, spread_deg=0.1, detections=5, score=3.5)
write(r + "rows.ndjson", "".join(json.dumps(x) + "\n" for x in recs + [event]))
doc = {"tool": {"name": "ssl", "version": "0.2.0"}, "geometry": {"name": "pair", "microphones": 2}, "parameters": {"threshold_sigmas": 3.0}, "detections": recs, "events": [event], "files": []}
write(r + "doc.json", json.dumps(doc, indent=1))
bad = dict(doc); bad["detections"] = recs[:2] + [dict(recs[2], score="high")]
write(r + "doc_bad_value.json", json.dumps(bad, indent=1))
write(r + "empty", "")
write(r + "garbage", bytes([0, 159, 146, 150, 7, 27, 91, 50, 74]))
write(r + "array.json", "[1,2,3]\n")
write(r + "hello.json", "\"hello\"\n")
write(r + "object.json", "{\"a\": 1}\n")

t = "truth/"
truth = {"tool": {"name": "ssl", "version": "0.2.0"}, "sample_rate": RATE, "duration_s": 0.2, "seed": 3,
         "array": {"geometry": "arrays/pair.toml", "position": [2.0, 2.0, 1.0], "yaw_deg": 0.0},
         "sources": [{"index": 0, "signal": "white", "level_db": -26.0, "position_room": [2.87, 2.5, 1.0],
                      "x": 0.866025, "y": 0.5, "z": 0.0, "azimuth_deg": 30.0, "elevation_deg": 0.0,
                      "distance_m": 1.0, "active": [[0.05, 0.15]]}]}
write(t + "truth.json", json.dumps(truth, indent=1))
write(t + "duration_huge.json", json.dumps(dict(truth, duration_s=1e300)))
write(t + "week.json", json.dumps(dict(truth, duration_s=604800.0, sample_rate=768000)))
rev = json.loads(json.dumps(truth)); rev["sources"][0]["active"] = [[0.8, 0.2]]
write(t + "reversed.json", json.dumps(rev))
zero = json.loads(json.dumps(truth)); zero["sources"][0].update(x=0.0, y=0.0, z=0.0)
write(t + "zero_vector.json", json.dumps(zero))
write(t + "empty.json", "")
