"""adaptations and adaptation_trials: adaptation sessions over repertoires, issue 44

Revision ID: 0005
Revises: 0004
"""

from alembic import op
import sqlalchemy as sa


revision = '0005'
down_revision = '0004'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table('adaptations',
    sa.Column('seq', sa.Integer(), autoincrement=True, nullable=False),
    sa.Column('id', sa.String(length=32), nullable=False),
    sa.Column('owner', sa.String(length=64), nullable=False),
    sa.Column('spec', sa.JSON(), nullable=False),
    sa.Column('status', sa.String(length=16), nullable=False),
    sa.Column('stop_reason', sa.Text(), nullable=True),
    sa.Column('trials', sa.Integer(), nullable=False),
    sa.Column('created_at', sa.DateTime(timezone=True), nullable=False),
    sa.Column('updated_at', sa.DateTime(timezone=True), nullable=False),
    sa.PrimaryKeyConstraint('seq'),
    sa.UniqueConstraint('id')
    )
    op.create_index('ix_adaptations_owner_seq', 'adaptations', ['owner', 'seq'], unique=False)
    op.create_table('adaptation_trials',
    sa.Column('adaptation_seq', sa.Integer(), nullable=False),
    sa.Column('index', sa.Integer(), nullable=False),
    sa.Column('map', sa.String(length=200), nullable=False),
    sa.Column('elite', sa.Integer(), nullable=False),
    sa.Column('forward_m', sa.Float(), nullable=False),
    sa.Column('lateral_m', sa.Float(), nullable=False),
    sa.Column('yaw_deg', sa.Float(), nullable=False),
    sa.Column('fell', sa.Boolean(), nullable=False),
    sa.Column('duration_s', sa.Float(), nullable=False),
    sa.Column('note', sa.Text(), nullable=False),
    sa.Column('proposal', sa.JSON(), nullable=False),
    sa.Column('created_at', sa.DateTime(timezone=True), nullable=False),
    sa.ForeignKeyConstraint(['adaptation_seq'], ['adaptations.seq'], ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('adaptation_seq', 'index')
    )


def downgrade() -> None:
    op.drop_table('adaptation_trials')
    op.drop_index('ix_adaptations_owner_seq', table_name='adaptations')
    op.drop_table('adaptations')
