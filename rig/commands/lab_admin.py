"""`rig lab roles|migrate|user`: setting up the lab's store and page (docs/guides/lab-setup.md).

`roles --sql` prints what an administrator runs (the tables, the roles `lab_rig`, `lab_reader`,
`lab_analyst`, their grants and row-level security, the logins); `migrate` applies the same to a database
as its owner; `user` adds a user of the page, hashed, to a users file.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from rig.commands.lab import lab_errors
from rig.exits import CommandError, Exit

RIG_HELP = "RIG=LOGIN: the database login that pushes rig RIG's sessions (repeatable)."


@click.group()
def lab():
    """Set up the lab's store and page: roles and their SQL, tables, users of the page."""


def login_options(f):
    f = click.option("--rig", "rigs", multiple=True, metavar="RIG=LOGIN", help=RIG_HELP)(f)
    f = click.option("--reader", "readers", multiple=True, metavar="LOGIN",
                     help="A login of the page or the questions: reads only (repeatable).")(f)
    return click.option("--analyst", "analysts", multiple=True, metavar="LOGIN",
                        help="A login of `rig batch`: reads, adds results and re-calibrations (repeatable).")(f)


@lab.command()
@click.option("--sql", "as_sql", is_flag=True, help="Print the SQL (to review, or run with psql -1 -f); without it, "
              "what each role may do.")
@click.option("--no-tables", is_flag=True, help="Leave out the lab tables (a database that has them).")
@login_options
def roles(as_sql, no_tables, rigs, readers, analysts):
    """Print the SQL of the lab's roles: a rig inserts its own sessions only, readers read, the owner migrates."""
    from rig.lab import roles as lab_roles

    if not as_sql:
        click.echo(lab_roles.SUMMARY, nl=False)
        return
    with lab_errors():
        text = lab_roles.script(rigs=lab_roles.parse_rig_logins(rigs), readers=list(readers),
                                analysts=list(analysts), schema=not no_tables)
    click.echo(text, nl=False)


@lab.command()
@click.option("--store", "store_url", required=True, envvar="RIG_STORE",
              help="postgresql://ADMIN@HOST:PORT/DB: connect as the tables' owner (or the one who will own them).")
@login_options
def migrate(store_url, rigs, readers, analysts):
    """Create the lab tables if missing and apply the roles, grants and row-level security (as their owner)."""
    from rig.lab import roles as lab_roles
    from rig.lab.errors import is_database_url, redact

    if not is_database_url(store_url):
        raise CommandError(f"{store_url}: migrate needs a postgresql:// store", Exit.BAD_INPUT)
    with lab_errors():
        logins = lab_roles.parse_rig_logins(rigs)
        lab_roles.migrate(store_url, rigs=logins, readers=list(readers), analysts=list(analysts))
    click.echo(f"{redact(store_url)}: lab tables and access rules in place")
    for rig_name, login in logins.items():
        click.echo(f"login {login}: pushes rig {rig_name}'s sessions (lab_rig)")
    for login in readers:
        click.echo(f"login {login}: reads (lab_reader)")
    for login in analysts:
        click.echo(f"login {login}: reads, adds batch results (lab_analyst)")


@lab.command()
@click.argument("name")
@click.option("--users", "users_file", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="The users file of `rig serve --users` (made if missing, mode 600).")
@click.option("--password-stdin", is_flag=True, help="Read the password from standard input (one line).")
def user(name, users_file, password_stdin):
    """Add a user of the page (or change its password): only its scrypt hash is written."""
    from rig.lab.web.auth import add_user

    if password_stdin:
        password = sys.stdin.readline().rstrip("\n")
    else:
        password = click.prompt(f"password for {name}", hide_input=True, confirmation_prompt=True)
    with lab_errors():
        add_user(users_file, name, password)
    click.echo(f"{users_file}: user {name} added")
