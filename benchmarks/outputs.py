"""What recording and the live view cost the node: real-time factor and bytes per second.

    .venv/bin/python -m benchmarks.outputs [--seconds 10] [--spheres 3,1000,10000]

One node process per row (as `ros2 run` starts it; physics 200 Hz, publishing 30 Hz,
real_time_factor 1; the default pool at 3 spheres with per-sphere topics, N scattered
spheres with per_sphere_topics false above that), with recording off/on and the Foxglove
server off/on. With the server on, one WebSocket client in this process subscribes to the 3D
scene (as Foxglove's 3D panel does; in the last row to every channel: the scene and the raw
state topics) and counts the bytes and the scene frames it receives. The real-time factor comes
from the node's own status lines over the last `--seconds` (node_rate.node_own_figures);
the recording's bytes from the file's growth over the same window.
"""
import argparse
import asyncio
import json
import os
from pathlib import Path
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time

from benchmarks.node_rate import node_own_figures, spheres_params_file

WARM_UP_S = 4.0
DOMAIN_ID = 100 + os.getpid() % 100


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


class Client:
    """A Foxglove WebSocket client (subprotocol foxglove.sdk.v1) on a thread: subscribes to
    the 3D scene (as Foxglove's 3D panel does), or with every_channel to every channel
    advertised, and counts bytes and messages per topic."""

    def __init__(self, port, every_channel=False):
        self.port, self.bytes, self.messages, self.topics = port, 0, {}, {}
        self.every_channel = every_channel
        self.running = True
        self.thread = threading.Thread(target=lambda: asyncio.run(self._run()), daemon=True)
        self.thread.start()

    async def _run(self):
        import websockets
        for _ in range(200):  # the server starts with the node
            try:
                socket_ = await websockets.connect(f'ws://127.0.0.1:{self.port}',
                                                   subprotocols=['foxglove.sdk.v1'],
                                                   max_size=None)
                break
            except OSError:
                await asyncio.sleep(0.1)
        else:
            return
        async with socket_:
            subscribed = 0
            while self.running:
                try:
                    frame = await asyncio.wait_for(socket_.recv(), 0.5)
                except asyncio.TimeoutError:
                    continue
                if isinstance(frame, str):
                    message = json.loads(frame)
                    if message.get('op') == 'advertise':
                        subscriptions = []
                        for channel in message['channels']:
                            if not (self.every_channel or channel['topic'].endswith('/scene')):
                                continue
                            subscribed += 1
                            self.topics[subscribed] = channel['topic']
                            subscriptions.append({'id': subscribed, 'channelId': channel['id']})
                        await socket_.send(json.dumps({'op': 'subscribe',
                                                       'subscriptions': subscriptions}))
                    continue
                self.bytes += len(frame)
                if frame[0] == 1:  # message data: opcode, subscription id, log time, payload
                    topic = self.topics.get(int.from_bytes(frame[1:5], 'little'))
                    self.messages[topic] = self.messages.get(topic, 0) + 1

    def counts(self):
        return self.bytes, dict(self.messages)

    def stop(self):
        self.running = False
        self.thread.join(timeout=5.0)


def measure(params_file, seconds, record_path=None, foxglove=False, every_channel=False):
    """(node RTF, recording bytes per wall s, client bytes per wall s, scene frames per
    wall s, simulated s in the window)."""
    arguments = [sys.executable, '-m', 'pool_sim', '--ros-args', '-p', 'real_time_factor:=1.0']
    if params_file is not None:
        arguments += ['--params-file', str(params_file)]
    if record_path is not None:
        arguments += ['-p', f'record:={record_path}']
    port = free_port() if foxglove else None
    if port is not None:
        arguments += ['-p', f'foxglove_port:={port}']
    node = subprocess.Popen(arguments, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True, env={**os.environ, 'ROS_DOMAIN_ID': str(DOMAIN_ID)})
    client = Client(port, every_channel) if foxglove else None
    log = []
    reader = threading.Thread(target=lambda: log.extend(node.stderr), daemon=True)
    reader.start()
    try:
        while not any('first state published' in line for line in log):
            if node.poll() is not None:
                raise RuntimeError(''.join(log[-5:]))
            time.sleep(0.1)
        time.sleep(WARM_UP_S)
        start = time.monotonic()
        size_before = record_path.stat().st_size if record_path else 0
        seen_before = client.counts() if client else (0, {})
        time.sleep(seconds + 5.5)  # the window and the status line after it
        wall = time.monotonic() - start
        size_after = record_path.stat().st_size if record_path else 0
        seen_after = client.counts() if client else (0, {})
    finally:
        if client is not None:
            client.stop()
        node.send_signal(signal.SIGINT)
        node.wait(timeout=300)
        reader.join(timeout=10)
    own = node_own_figures(''.join(log), seconds)
    rtf = own[0] if own else float('nan')
    scene_frames = sum(count - seen_before[1].get(topic, 0)
                       for topic, count in seen_after[1].items()
                       if topic and 'scene' in topic and 'markers' not in topic)
    return (rtf, (size_after - size_before) / wall, (seen_after[0] - seen_before[0]) / wall,
            scene_frames / wall, record_path.stat().st_size if record_path else 0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=10.0)
    parser.add_argument('--spheres', default='3,1000,10000')
    args = parser.parse_args()
    print(f'physics 200 Hz, publishing 30 Hz, real_time_factor 1; window {args.seconds:g} s '
          'after a 4 s warm-up; RTF from the node\'s own status lines')
    print('| spheres | recording | Foxglove | node RTF | recording kB / wall s | '
          'recording B / sphere / simulated s | Foxglove client kB / wall s | '
          '3D frames / wall s |')
    print('|---:|---|---|---:|---:|---:|---:|---:|')
    with tempfile.TemporaryDirectory() as folder:
        for count in (int(n) for n in args.spheres.split(',') if n):
            params = None
            if count != 3:
                params = spheres_params_file(count, Path(folder) / f's{count}.yaml')
                text = params.read_text().replace(
                    'ros__parameters:\n', 'ros__parameters:\n    per_sphere_topics: false\n', 1)
                params.write_text(text)
            for record in (False, True):
                for foxglove in (False, True):
                    path = Path(folder) / f'run{count}.mcap' if record else None
                    rtf, record_rate, client_rate, frames, _ = measure(
                        params, args.seconds, path, foxglove)
                    per_sphere = record_rate / rtf / count if record else 0.0
                    print(f'| {count:,} | {"on" if record else "off"} | '
                          f'{"on" if foxglove else "off"} | {rtf:.3f} | '
                          f'{record_rate / 1e3:.0f} | {per_sphere:.0f} | '
                          f'{client_rate / 1e3:.0f} | {frames:.1f} |', flush=True)
                    if path is not None:
                        path.unlink()
            if count == max(int(n) for n in args.spheres.split(',') if n):
                rtf, _, client_rate, frames, _ = measure(params, args.seconds, None, True, True)
                print(f'| {count:,} | off | on, every channel | {rtf:.3f} | | | '
                      f'{client_rate / 1e3:.0f} | {frames:.1f} |', flush=True)


if __name__ == '__main__':
    main()
