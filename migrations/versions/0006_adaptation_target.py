"""adaptations.target_m_s: the recovery target fixed when a session is created, issue 44 (a
session over an uploaded robot's maps gets its robot's target, measured on the stored model)

Revision ID: 0006
Revises: 0005
"""

from alembic import op
import sqlalchemy as sa


revision = '0006'
down_revision = '0005'
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table('adaptations') as batch:
        batch.add_column(sa.Column('target_m_s', sa.Float(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table('adaptations') as batch:
        batch.drop_column('target_m_s')
