/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | TunnelQuake: water side, built against
   \\    /   O peration     | OpenFOAM v1912
    \\  /    A nd           |
     \\/     M anipulation  |
-------------------------------------------------------------------------------
License
    GPL-3.0-or-later, like the OpenFOAM libraries it links against.

\*---------------------------------------------------------------------------*/

#include "interfaceTraction.H"

// * * * * * * * * * * * * * * * Global Functions  * * * * * * * * * * * * * //

Foam::List<Foam::scalarList> Foam::tq::medianDualWeights
(
    const faceList& faces,
    const pointField& points
)
{
    List<scalarList> weights(faces.size());

    forAll(faces, facei)
    {
        const face& f = faces[facei];
        const point c = f.centre(points);
        const label n = f.size();

        // Triangle (c, p_k, p_k+1): half of it (split at the edge mid-point)
        // belongs to p_k, the other half to p_k+1.
        scalarList& w = weights[facei];
        w.setSize(n, 0.0);
        scalar sumA = 0;
        for (label k = 0; k < n; ++k)
        {
            const point& a = points[f[k]];
            const point& b = points[f.nextLabel(k)];
            const scalar halfA = 0.25*mag((a - c) ^ (b - c));
            w[k] += halfA;
            w[(k + 1) % n] += halfA;
            sumA += 2*halfA;
        }

        if (sumA > VSMALL)
        {
            for (scalar& wk : w)
            {
                wk /= sumA;
            }
        }
        else
        {
            w = 1.0/n;
        }
    }

    return weights;
}


Foam::tmp<Foam::vectorField> Foam::tq::distributeToPoints
(
    const faceList& faces,
    const List<scalarList>& weights,
    const label nPoints,
    const vectorField& faceForces
)
{
    tmp<vectorField> tpf(new vectorField(nPoints, Zero));
    vectorField& pf = tpf.ref();

    forAll(faces, facei)
    {
        const face& f = faces[facei];
        const scalarList& w = weights[facei];
        forAll(f, k)
        {
            pf[f[k]] += w[k]*faceForces[facei];
        }
    }

    return tpf;
}


Foam::tmp<Foam::scalarField> Foam::tq::pointAreas
(
    const faceList& faces,
    const List<scalarList>& weights,
    const label nPoints,
    const scalarField& faceAreas
)
{
    tmp<scalarField> tpa(new scalarField(nPoints, 0.0));
    scalarField& pa = tpa.ref();

    forAll(faces, facei)
    {
        const face& f = faces[facei];
        const scalarList& w = weights[facei];
        forAll(f, k)
        {
            pa[f[k]] += w[k]*faceAreas[facei];
        }
    }

    return tpa;
}


// ************************************************************************* //
