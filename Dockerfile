# Observability explorer, served by Panel on port 5006.
#
#   docker build -t dipole-observability .
#   docker run --rm -p 5006:5006 dipole-observability        # then open http://localhost:5006/
#
# Served behind another host name or port, the browser's origin must be allowed for the websocket:
#   docker run -p 8080:5006 -e BOKEH_ALLOW_WS_ORIGIN=dash.example.org,localhost:8080 dipole-observability
# Session ids are signed with BOKEH_SECRET_KEY; if it is not set, the entrypoint makes a random one
# per container start (fine for one container; replicas behind a load balancer must share one).
FROM debian:bookworm-slim

ARG DEBIAN_FRONTEND=noninteractive
ENV PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1

# Debian's Python only; numpy/scipy/numba/llvmlite come as manylinux wheels, so no compiler.
# libgomp1: numba's OpenMP threading layer for the maps' kernels (app/__init__.py sets its threads
# to sleep between parallel regions; without it numba falls back to its own workqueue).
RUN apt-get update \
 && apt-get install -y --no-install-recommends python3 python3-venv libgomp1 \
 && apt-get clean \
 && rm -rf /var/lib/apt/lists/*

RUN python3 -m venv /opt/venv
ENV PATH=/opt/venv/bin:$PATH

WORKDIR /srv/dipole

# Dependencies first, from pyproject.toml alone, so that editing core/ or app/ rebuilds in seconds.
COPY pyproject.toml ./
RUN python -c "import tomllib; print(*tomllib.load(open('pyproject.toml', 'rb'))['project']['dependencies'], sep='\n')" > /tmp/requirements.txt \
 && pip install -r /tmp/requirements.txt \
 && rm /tmp/requirements.txt

COPY . ./
RUN pip install --no-deps . \
 && pip check

# Unprivileged user with a writable home; the installed code stays root-owned and read-only,
# so numba's on-disk cache (cache=True kernels) goes to NUMBA_CACHE_DIR instead of __pycache__.
RUN useradd --create-home --home-dir /home/dipole --uid 10001 --user-group --shell /usr/sbin/nologin dipole \
 && install -d -o dipole -g dipole /home/dipole/.cache /home/dipole/.cache/numba
# PYTHONMALLOC=malloc: Python's own small-object allocator keeps every 1 MiB arena that still
# holds one live object, so the memory of closed sessions never went back (+29 % after 20
# sessions, though tracemalloc counted their objects all freed); with glibc's malloc and the
# malloc_trim each closed session does, it comes back within a few per cent (bench/load_test.py).
ENV HOME=/home/dipole \
    NUMBA_CACHE_DIR=/home/dipole/.cache/numba \
    PYTHONMALLOC=malloc \
    BOKEH_ALLOW_WS_ORIGIN=localhost:5006,127.0.0.1:5006
USER 10001:10001
# Compile every numba kernel once at build time into NUMBA_CACHE_DIR (app.serve.warmup: the list the
# server itself warms up with, ~3-6 min of LLVM on 2 cores), and build the app once (HoloViews'
# first import makes matplotlib's font cache), so that the first visitor does not wait. -P: import
# the installed packages, as the server does (not ./core, whose numba cache would sit elsewhere).
RUN python -P -m app.serve.warmup \
 && python -P -c "import panel as pn; pn.extension('tabulator'); import app.page as d; d.create_app()"

EXPOSE 5006
HEALTHCHECK --interval=30s --timeout=5s --start-period=60s --retries=3 \
  CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:5006/liveness', timeout=4)"]

# bokeh/tornado exit cleanly on SIGINT (KeyboardInterrupt); as PID 1 a plain SIGTERM would be ignored.
STOPSIGNAL SIGINT
# --session-ids signed needs BOKEH_SECRET_KEY: make a random one unless given, then exec the CMD so
# that the server is PID 1 and gets the stop signal itself.
ENTRYPOINT ["/bin/sh", "-c", "export BOKEH_SECRET_KEY=\"${BOKEH_SECRET_KEY:-$(python -c 'import secrets; print(secrets.token_urlsafe(32))')}\"; exec \"$@\"", "entrypoint"]
# One process with a pool of 4 threads for session callbacks (not --num-procs: one process keeps
# one numba cache and one secret key); sessions whose browser tab is gone are checked every 10 s
# and dropped after 60 s. No --admin, no --autoreload.
CMD ["panel", "serve", "app/main.py", \
     "--address", "0.0.0.0", "--port", "5006", \
     "--index", "main", \
     "--liveness", \
     "--num-threads", "4", \
     "--check-unused-sessions", "10000", "--unused-session-lifetime", "60000", \
     "--session-ids", "signed"]
