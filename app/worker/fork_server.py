"""The worker's fork server ignores SIGTERM (imported there first, as part of its preload).

Workers are forked from a fork server (:mod:`app.worker.supervisor`), so the fork server is their
parent and carries their exit status to the supervisor. A service manager that stops homebot by
sending SIGTERM to every process of the service at once (systemd's default ``KillMode``) would
otherwise end the fork server first: the worker, bound to its parent
(:mod:`app.worker.lifeline`), would die before saving its map, and the supervisor would see a
worker gone that is still running. Ignoring SIGTERM here leaves it to the server and the worker
(which installs its own handler); the fork server still ends with the server, when the server's
end of its pipe closes.
"""

import signal

signal.signal(signal.SIGTERM, signal.SIG_IGN)
