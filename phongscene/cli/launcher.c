// SPDX-License-Identifier: Apache-2.0
// The `phongscene` command (issue 27.2): holds SIGINT, SIGTERM and SIGHUP back, then becomes the
// Python interpreter running phongscene.console.main, which installs its handlers and only then
// lets the held signals in. A signal mask survives execve, so a signal sent at any instant of the
// interpreter's start-up waits for a handler that ends the process with the documented status
// (130 / 143 / 129) and one line. A Python console script cannot do this: the interpreter starts,
// and a signal in its first ~30 ms (before the script's first line) killed it with the signal's
// default action (exit -N).
//
// The interpreter: `python3` beside this program (a virtual environment's bin/, where pip puts
// it), else the one the package was built for (PHONGSCENE_PYTHON).
#define _GNU_SOURCE
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifndef PHONGSCENE_PYTHON
#error "define PHONGSCENE_PYTHON: the interpreter the package is built for"
#endif

// sys.argv[0] names the command (argparse's "usage: phongscene"); `-c` puts the current folder
// first on sys.path, which a console script does not: it goes again.
static const char kBoot[] =
    "import sys\n"
    "if sys.path[:1] == ['']: del sys.path[0]\n"
    "sys.argv[0] = 'phongscene'\n"
    "from phongscene.console import main\n"
    "main()\n";

int main(int argc, char** argv) {
    sigset_t held;
    sigemptyset(&held);
    sigaddset(&held, SIGINT);
    sigaddset(&held, SIGTERM);
    sigaddset(&held, SIGHUP);
    sigprocmask(SIG_BLOCK, &held, NULL);

    char beside[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", beside, sizeof beside - sizeof "python3");
    char* slash = n > 0 ? memrchr(beside, '/', (size_t)n) : NULL;
    if (slash != NULL) strcpy(slash + 1, "python3");

    char** args = calloc((size_t)argc + 3, sizeof *args);
    if (args == NULL) {
        fputs("phongscene: error: out of memory\n", stderr);
        return 2;
    }
    args[1] = "-c";
    args[2] = (char*)kBoot;
    for (int i = 1; i < argc; ++i) args[i + 2] = argv[i];
    if (slash != NULL && access(beside, X_OK) == 0) {
        args[0] = beside;
        execv(beside, args);
    }
    args[0] = PHONGSCENE_PYTHON;
    execv(PHONGSCENE_PYTHON, args);
    fprintf(stderr, "phongscene: error: cannot start Python (%s): %s\n", PHONGSCENE_PYTHON, strerror(errno));
    return 2;
}
