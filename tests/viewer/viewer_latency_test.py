#!/usr/bin/python3
"""scripts/viewer-latency end to end, with no node: a CPU caustica-server with the viewer, a
bundled scene uploaded at a test-sized resolution by the caustica CLI, then the script against it.
Passes when the script exits 0 and its last line is a viewer_latency_median with a positive value.

  viewer_latency_test.py [--scene ring] [--width 192] [--height 144] [--photons 20000]
      [-- ARGS FOR scripts/viewer-latency]

CAUSTICA_SERVER_BIN, CAUSTICA_CLIENT_BIN and CAUSTICA_SCENES_DIR name the inputs; exits 77
(skipped) when the chromium ($CHROMIUM, else /usr/bin/chromium) is missing. With --keep it prints
the viewer's address and the scene id and keeps the server until interrupted, for measuring by
hand.
"""

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

SKIP = 77
HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, '..', '..', 'scripts', 'viewer-latency')


def fail(message):
    print(f'FAIL: {message}', file=sys.stderr)
    sys.exit(1)


def wait_for_file(path, server, log_path, seconds=30):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if os.path.exists(path):
            text = open(path).read().strip()
            if text:
                return int(text)
        if server.poll() is not None:
            break
        time.sleep(0.05)
    fail(f'caustica-server did not write {path}; its log:\n{open(log_path).read()}')


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument('--scene', default='ring')
    parser.add_argument('--width', type=int, default=192)
    parser.add_argument('--height', type=int, default=144)
    parser.add_argument('--photons', type=int, default=20000)
    parser.add_argument('--keep', action='store_true')
    parser.add_argument('script_args', nargs='*')
    args = parser.parse_args()
    chromium = os.environ.get('CHROMIUM') or '/usr/bin/chromium'
    if not os.path.exists(chromium):
        print(f'SKIP: {chromium} is missing (apt-get install chromium)')
        sys.exit(SKIP)
    inputs = {name: os.environ.get(name) for name in
              ('CAUSTICA_SERVER_BIN', 'CAUSTICA_CLIENT_BIN', 'CAUSTICA_SCENES_DIR')}
    for name, value in inputs.items():
        if not value:
            print(f'{name} is not set', file=sys.stderr)
            sys.exit(2)

    work = tempfile.mkdtemp(prefix='caustica-viewer-latency-test-')
    scene = json.load(open(os.path.join(inputs['CAUSTICA_SCENES_DIR'], args.scene, 'scene.json')))
    scene['camera']['width'] = args.width
    scene['camera']['height'] = args.height
    scene['settings']['photons'] = args.photons
    scene_file = os.path.join(work, 'scene.json')
    json.dump(scene, open(scene_file, 'w'))

    port_file = os.path.join(work, 'port')
    log_path = os.path.join(work, 'server.log')
    with open(log_path, 'w') as log:
        server = subprocess.Popen(
            [inputs['CAUSTICA_SERVER_BIN'], '--listen', '127.0.0.1:0', '--port-file', port_file,
             '--http-listen', '127.0.0.1:0', '--http-port-file', f'{port_file}-http',
             '--device', 'cpu'], stdin=subprocess.DEVNULL, stdout=log, stderr=log)
    try:
        grpc_port = wait_for_file(port_file, server, log_path)
        http_port = wait_for_file(f'{port_file}-http', server, log_path)
        upload = subprocess.run(
            [inputs['CAUSTICA_CLIENT_BIN'], '--server', f'127.0.0.1:{grpc_port}', '--json', 'scene',
             'upload', scene_file, '--name', f'{args.scene}-latency'],
            capture_output=True, text=True, env={**os.environ, 'CAUSTICA_DATA_DIR': ''})
        if upload.returncode != 0:
            fail(f'scene upload failed:\n{upload.stdout}{upload.stderr}')
        scene_id = json.loads(upload.stdout)['scene_id']
        viewer = f'http://127.0.0.1:{http_port}'
        if args.keep:
            print(json.dumps({'viewer': viewer, 'scene': scene_id}), flush=True)
            signal.pthread_sigmask(signal.SIG_BLOCK, [signal.SIGINT, signal.SIGTERM])
            signal.sigwait([signal.SIGINT, signal.SIGTERM])
            return
        run = subprocess.run([sys.executable, SCRIPT, '--viewer', viewer, '--scene', scene_id,
                              *args.script_args], capture_output=True, text=True)
        sys.stdout.write(run.stdout)
        sys.stderr.write(run.stderr)
        if run.returncode != 0:
            fail(f'scripts/viewer-latency exited with {run.returncode}')
        lines = run.stdout.strip().splitlines()
        last = json.loads(lines[-1]) if lines else {}
        if last.get('name') != 'viewer_latency_median' or not last.get('value', 0) > 0:
            fail(f'no positive viewer_latency_median in:\n{run.stdout}')
        print('PASS: viewer latency')
    finally:
        server.send_signal(signal.SIGTERM)
        try:
            code = server.wait(30)
        except subprocess.TimeoutExpired:
            server.kill()
            code = 'killed after 30 s'
        log = open(log_path).read()
        shutil.rmtree(work, ignore_errors=True)
        if code != 0 and not args.keep:
            fail(f'caustica-server exited with {code}; its log:\n{log}')


if __name__ == '__main__':
    main()
