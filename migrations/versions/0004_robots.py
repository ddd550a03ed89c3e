"""robots table: uploaded robots (owner, content hash, name, leg map, sizes), issue 23

Revision ID: 0004
Revises: 0003
"""

from alembic import op
import sqlalchemy as sa


revision = '0004'
down_revision = '0003'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table('robots',
    sa.Column('seq', sa.Integer(), autoincrement=True, nullable=False),
    sa.Column('id', sa.String(length=32), nullable=False),
    sa.Column('owner', sa.String(length=64), nullable=False),
    sa.Column('content_hash', sa.String(length=64), nullable=False),
    sa.Column('name', sa.String(length=200), nullable=False),
    sa.Column('legs', sa.JSON(), nullable=False),
    sa.Column('info', sa.JSON(), nullable=False),
    sa.Column('created_at', sa.DateTime(timezone=True), nullable=False),
    sa.PrimaryKeyConstraint('seq'),
    sa.UniqueConstraint('id'),
    sa.UniqueConstraint('owner', 'content_hash', name='uq_robots_owner_content_hash')
    )
    op.create_index('ix_robots_owner_seq', 'robots', ['owner', 'seq'], unique=False)


def downgrade() -> None:
    op.drop_index('ix_robots_owner_seq', table_name='robots')
    op.drop_table('robots')
