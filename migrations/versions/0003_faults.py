"""jobs.held (study points not yet admitted to the queue), jobs.interrupted_at (the worker
running the job was asked to stop: the attempt is not spent), workers.slots (task slots,
to tell idle workers from busy ones)

Revision ID: 0003
Revises: 0002
"""

from alembic import op
import sqlalchemy as sa


revision = '0003'
down_revision = '0002'
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table('jobs', schema=None) as batch_op:
        batch_op.add_column(sa.Column('held', sa.Boolean(), nullable=False, server_default=sa.false()))
        batch_op.add_column(sa.Column('interrupted_at', sa.DateTime(timezone=True), nullable=True))
    with op.batch_alter_table('workers', schema=None) as batch_op:
        batch_op.add_column(sa.Column('slots', sa.Integer(), nullable=False, server_default='1'))


def downgrade() -> None:
    with op.batch_alter_table('workers', schema=None) as batch_op:
        batch_op.drop_column('slots')
    with op.batch_alter_table('jobs', schema=None) as batch_op:
        batch_op.drop_column('interrupted_at')
        batch_op.drop_column('held')
